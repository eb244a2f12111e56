"""``arrayproc track``: one entry for every tracker configuration.

The tracker TOML is read once (:func:`arrayproc.config.read_toml`) and its ``[tracker]`` mapping
dispatched on its ``type`` (:mod:`arrayproc.track.types`): ``type = "single"`` (the default;
the papers' reproductions) runs the single-target bearings tracker of
:mod:`arrayproc.track.single`; ``type = "multi"`` runs the track manager over every contact
(:mod:`arrayproc.track.multi`); ``type = "delays"`` the recursive TDOA position tracker
(:mod:`arrayproc.track.delays`). The older ``mode = "multi"`` (with ``measurements =
"delays"`` for the TDOA tracker) still means the same. Each runner is a thin
composition of the parts (models, filters, the hypothesis bank, the manager's associator,
initiator, confirmer and deleter) that a user can also put together in Python; this module
only dispatches, so neither runner imports the other's entry point (no import cycle).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from arrayproc.config import read_toml
from arrayproc.errors import ConfigError
from arrayproc.track.delays import check_delays_config, run_delays
from arrayproc.track.multi import check_multi_config, run_multi
from arrayproc.track.multi.fused_run import run_fused
from arrayproc.track.single import (  # noqa: F401  (re-exported for callers of the runner)
    _read_bearings,
    assign_by_continuity,
    check_single_config,
    load_single_config,
    ownship_states,
    run_single,
    track_bearings,
)
from arrayproc.track.types import tracker_type


def check_tracker_config(t: Any, path: str) -> dict[str, Any]:
    """Check the ``[tracker]`` mapping of a tracker TOML of any mode.

    Parameters
    ----------
    t : dict
        The parsed ``[tracker]`` table.
    path : str
        The file it came from (for messages).

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
    kind = tracker_type(t, path)
    if kind == "delays":  # the TDOA tracker (track/delays)
        return {**check_delays_config(t, path), "type": kind}
    if kind == "multi":  # the multi-target keys, then the TMA filter's
        multi, tma = check_multi_config(t, path)
        return {**tma, "mode": "multi", "multi": multi, "type": kind}
    if kind != "single":
        raise ConfigError(f"{path}: tracker.mode must be 'single' or 'multi', not {kind!r} "
                          "(or name the tracker with tracker.type = 'single', 'multi' or "
                          "'delays')")
    return check_single_config(t, path)


def load_tracker_config(path: str) -> dict[str, Any]:
    """Read (once) and check a tracker TOML of any mode (:func:`check_tracker_config`).

    Parameters
    ----------
    path : str
        Tracker TOML (docs/formats.md).

    Returns
    -------
    dict
        The checked settings.
    """
    doc, _ = read_toml(path, "tracker")
    return check_tracker_config(doc.get("tracker"), path)


def check_one_input(paths: Sequence[str], config_path: str, cfg: dict[str, Any]) -> None:
    """ConfigError unless ``paths`` is one products file: only ``measurements =
    "fused_bearings"`` tracks several arrays' files together."""
    if len(paths) == 1:
        return
    what = (f"tracker.measurements = {cfg['multi']['measurements']!r}"
            if cfg.get("mode") == "multi" else f"tracker.type = {cfg.get('type', 'single')!r}")
    raise ConfigError(f"{config_path}: {what} reads one products file; {len(paths)} were "
                      "given (several static arrays: measurements = 'fused_bearings', e.g. "
                      "trackers/compact_fused.toml)")


def run_tracker(products_path: str | Sequence[str], config_path: str, out_path: str,
                progress: bool = False, cfg: dict[str, Any] | None = None) -> None:
    """``arrayproc track PRODUCTS.h5 -c TRACKER.toml -o TRACKS.h5``.

    Parameters
    ----------
    products_path : str or sequence of str
        Products file with ``bearings`` (or ``contacts``, ``positions``, ``delays``) rows;
        with ``measurements = "fused_bearings"`` one per static array (two or more), the
        other trackers refuse several.
    config_path : str
        Tracker TOML.
    out_path : str
        Tracks file to write (atomically).
    progress : bool
        Show a progress bar on stderr.
    cfg : dict, optional
        :func:`load_tracker_config` of ``config_path`` when the caller has it already (the
        file is then not read again).

    Returns
    -------
    None
    """
    if cfg is None:
        cfg = load_tracker_config(config_path)
    paths = [products_path] if isinstance(products_path, str) else list(products_path)
    fused = cfg.get("mode") == "multi" and cfg["multi"]["measurements"] == "fused_bearings"
    if fused:  # several static arrays in one tracker (arrayproc.track.multi.fused)
        tma = {k: v for k, v in cfg.items() if k not in ("mode", "multi", "type")}
        run_fused(paths, config_path, out_path, progress=progress, checked=(cfg["multi"], tma))
        return
    check_one_input(paths, config_path, cfg)
    products_path = paths[0]
    if cfg.get("mode") == "multi" and cfg["multi"]["measurements"] == "delays":
        run_delays(products_path, config_path, out_path, progress=progress, cfg=cfg)
    elif cfg.get("mode") == "multi":  # every target (arrayproc.track.multi)
        tma = {k: v for k, v in cfg.items() if k not in ("mode", "multi")}
        run_multi(products_path, config_path, out_path, progress=progress,
                  checked=(cfg["multi"], tma))
    else:
        run_single(products_path, config_path, out_path, progress=progress, cfg=cfg)
