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
                inputs: Sequence[str] = (), sensitivity_db: float | None = None,
                gain_db: float | None = None, full_scale_volts: float | None = None,
                response: str | None = None) -> dict[str, Any]:
    """Turn field recordings (WAV, FLAC, AIFF, …) into one recording file, calibrated to
    pascals when a scale or a sensitivity is given.

    Parameters
    ----------
    wavs : list of str
        One multichannel audio file or one mono file per hydrophone (channels in the natural
        order of the names, hyd2 before hyd10, with a notice when that is not the order given;
        an ambiguous order is refused: :func:`arrayproc.io.wav.channel_order`). WAV is read by
        :mod:`arrayproc.io.wav`, FLAC, AIFF and the other formats by libsndfile
        (:mod:`arrayproc.io.audio`).
    output : str
        Recording HDF5 file to write.
    positions : (n, 3) array, optional
        Element positions, m.
    scale : float, optional
        Pa per full scale (finite, non-zero); default: samples stored in full-scale units.
    sensitivity_db : float, optional
        Hydrophone sensitivity, dB re 1 V/µPa: the samples become pascals by
        :func:`arrayproc.io.calibration.pascals_per_full_scale` (needs ``full_scale_volts``).
    gain_db : float, optional
        Gain between hydrophone and converter, dB (default 0).
    full_scale_volts : float, optional
        Voltage of the converter's full scale, V.
    response : str, optional
        Frequency-response CSV (``freq_hz, sensitivity_db``) instead of ``sensitivity_db``:
        the samples are corrected by its inverse as a filter
        (:class:`arrayproc.io.calibration.ResponseFilter`).
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
    check_output(output, [*wavs, *inputs, *([response] if response else [])])
    if scale is not None and not (finite(scale) and scale != 0):
        raise FormatError(f"--scale must be a finite non-zero number of Pa per full scale, "
                          f"got {scale:g}")
    if not (finite(sound_speed) and sound_speed > 0):
        raise FormatError(f"--sound-speed must be a finite number > 0 m/s, got {sound_speed:g}")
    cal = calibration(scale, sensitivity_db, gain_db, full_scale_volts, response)
    from arrayproc.io.wav import import_wavs as _import
    return _import(wavs, output, positions=positions, scale=scale, sound_speed=sound_speed,
                   start_time=start_time or start_time_from_names(wavs), warn=warn,
                   calibration=cal)


def calibration(scale: float | None, sensitivity_db: float | None, gain_db: float | None,
                full_scale_volts: float | None, response: str | None) -> Any:
    """The :class:`arrayproc.io.calibration.Calibration` the import options give, or None
    (no option: full-scale units, or ``--scale`` alone); one line for options that conflict or
    are incomplete."""
    given = {k: v for k, v in (("--sensitivity", sensitivity_db), ("--gain", gain_db),
                               ("--full-scale-volts", full_scale_volts),
                               ("--response", response)) if v is not None}
    if not given:
        return None
    if scale is not None:
        raise ConfigError(f"import: --scale and {', '.join(given)} both calibrate the samples; "
                          "give one")
    if sensitivity_db is None and response is None:
        raise ConfigError(f"import: {', '.join(given)} needs --sensitivity DB (re 1 V/µPa) or "
                          "--response CSV")
    if sensitivity_db is not None and response is not None:
        raise ConfigError("import: give --sensitivity or --response, not both")
    if full_scale_volts is None:
        raise ConfigError("import: --sensitivity/--response needs --full-scale-volts V (the "
                          "voltage of the recorder's full scale)")
    from arrayproc.io.calibration import Calibration
    cal = Calibration(sensitivity_db, 0.0 if gain_db is None else gain_db, full_scale_volts,
                      response)
    cal.check()
    return cal


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
