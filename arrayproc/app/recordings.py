"""``arrayproc import`` and ``arrayproc simulate``: the two ways a recording file is made, from
WAV field recordings or from a scenario TOML; options are checked before any output is
started.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from arrayproc.app.options import finite
from arrayproc.app.progress import Echo, stderr_warning
from arrayproc.errors import ConfigError, FormatError
from arrayproc.io.atomic import check_output


def start_time_from_names(paths: Sequence[str]) -> str | None:
    """ISO-8601 start time from a file name holding ``YYYYMMDDTHHMMSSZ``, else None."""
    m = re.search(r"(\d{4})(\d{2})(\d{2})T(\d{2})(\d{2})(\d{2})Z", Path(paths[0]).name)
    if not m:
        return None
    y, mo, d, h, mi, s = m.groups()
    return f"{y}-{mo}-{d}T{h}:{mi}:{s}Z"


def import_wavs(wavs: Sequence[str], output: str, positions: Any = None,
                scale: float | None = None, sound_speed: float = 1500.0,
                start_time: str | None = None, warn: Echo = stderr_warning,
                inputs: Sequence[str] = ()) -> dict[str, Any]:
    """Turn WAV field recordings into one recording file.

    Parameters
    ----------
    wavs : list of str
        One multichannel WAV or one mono WAV per hydrophone (channels in the natural order of
        the names, hyd2 before hyd10, with a notice when that is not the order given; an
        ambiguous order is refused: :func:`arrayproc.io.wav.channel_order`).
    output : str
        Recording HDF5 file to write.
    positions : (n, 3) array, optional
        Element positions, m.
    scale : float, optional
        Pa per full scale (finite, non-zero); default: samples stored in full-scale units.
    sound_speed : float
        m/s, finite and > 0.
    start_time : str, optional
        ISO-8601 UTC start; default from the first file's name when it holds one.
    warn : callable
        Where warnings go (unequal lengths, truncated data).
    inputs : list of str
        Further input files (e.g. the geometry file) the output must not replace.

    Returns
    -------
    dict
        ``fs`` (Hz), ``n_channels``, ``n_samples``, ``format``, ``cut``.
    """
    check_output(output, [*wavs, *inputs])
    if scale is not None and not (finite(scale) and scale != 0):
        raise FormatError(f"--scale must be a finite non-zero number of Pa per full scale, "
                          f"got {scale:g}")
    if not (finite(sound_speed) and sound_speed > 0):
        raise FormatError(f"--sound-speed must be a finite number > 0 m/s, got {sound_speed:g}")
    from arrayproc.io.wav import import_wavs as _import
    return _import(wavs, output, positions=positions, scale=scale, sound_speed=sound_speed,
                   start_time=start_time or start_time_from_names(wavs), warn=warn)


def simulate(scenario: str, output: str, seed: int | None = None,
             duration: float | None = None, progress: bool = False,
             warn: Echo = stderr_warning) -> Path:
    """Simulate a recording from a scenario TOML.

    Parameters
    ----------
    scenario : str
        Scenario TOML file.
    output : str
        Recording HDF5 file to write.
    seed : int, optional
        Overrides the scenario's seed (0 <= seed < 2**64).
    duration : float, optional
        Shortens the scenario, s (finite, > 0).
    progress : bool
        Progress bar on stderr, in seconds of audio.
    warn : callable
        Where warnings go.

    Returns
    -------
    Path
        The written file.
    """
    check_output(output, [scenario])
    if seed is not None and not 0 <= seed < 2**64:
        raise ConfigError(f"--seed must be in 0..2**64-1, got {seed}")
    if duration is not None and not (finite(duration) and duration > 0):
        raise ConfigError(f"--duration must be a finite number > 0 s, got {duration:g}")
    from arrayproc.app.progress import audio_bar
    from arrayproc.sim.run import simulate_file
    bar = audio_bar(progress, "simulate")
    try:
        return simulate_file(scenario, output, seed=seed, duration=duration, progress=bar,
                             warn=warn)
    finally:
        if bar is not None:
            bar.close()
