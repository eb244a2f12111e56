"""``arrayproc track``: one entry for every tracker configuration.

``[tracker] mode = "single"`` (the default; the papers' reproductions) runs the single-target
bearings tracker of :mod:`arrayproc.track.single`; ``mode = "multi"`` runs the track manager
over every contact (:mod:`arrayproc.track.multi`), or with ``measurements = "delays"`` the
recursive TDOA position tracker (:mod:`arrayproc.track.delays`). This module only
dispatches, so neither runner imports the other's entry point (no import cycle).
"""

from __future__ import annotations

from typing import Any

from arrayproc.errors import ConfigError
from arrayproc.track.delays import is_delays_config, load_delays_config, run_delays
from arrayproc.track.multi import run_multi, split_config, tracker_mode
from arrayproc.track.single import (  # noqa: F401  (re-exported for callers of the runner)
    _read_bearings,
    assign_by_continuity,
    load_single_config,
    ownship_states,
    run_single,
    track_bearings,
)


def load_tracker_config(path: str) -> dict[str, Any]:
    """Read and check a tracker TOML of either mode.

    Parameters
    ----------
    path : str
        Tracker TOML (docs/formats.md).

    Returns
    -------
    dict
        The checked settings; with ``mode = "multi"`` the TMA filter's keys plus
        ``"mode": "multi"`` and the manager's settings under ``"multi"``.

    Raises
    ------
    ConfigError
        Naming the file and the key.
    """
    mode = tracker_mode(path)
    if mode == "multi" and is_delays_config(path):  # the TDOA tracker (track/delays.py)
        return load_delays_config(path)
    if mode == "multi":  # the multi-target keys, then the TMA filter's
        multi, tma = split_config(path)
        return {**tma, "mode": "multi", "multi": multi}
    return load_single_config(path)


def run_tracker(products_path: str, config_path: str, out_path: str,
                progress: bool = False) -> None:
    """``arrayproc track PRODUCTS.h5 -c TRACKER.toml -o TRACKS.h5``.

    Parameters
    ----------
    products_path : str
        Products file with ``bearings`` (or ``contacts``, ``positions``) rows.
    config_path : str
        Tracker TOML.
    out_path : str
        Tracks file to write (atomically).
    progress : bool
        Show a progress bar on stderr.

    Returns
    -------
    None
    """
    mode = tracker_mode(config_path)
    if mode == "multi" and is_delays_config(config_path):  # delays rows (track/delays.py)
        run_delays(products_path, config_path, out_path, progress=progress)
        return
    if mode == "multi":  # every target (arrayproc.track.multi)
        run_multi(products_path, config_path, out_path, progress=progress)
        return
    if mode != "single":
        raise ConfigError(f"{config_path}: tracker.mode must be 'single' or 'multi', not "
                          f"{mode!r}")
    run_single(products_path, config_path, out_path, progress=progress)
