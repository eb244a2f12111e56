"""``arrayproc track A.h5 B.h5 … -c compact_fused.toml -o TRACKS.h5``: the azimuths of two or
more static arrays tracked together (:mod:`arrayproc.track.multi.fused`), written as one
``tracks`` group in the recordings' local frame."""

from __future__ import annotations

import logging
import os
from collections.abc import Sequence
from typing import Any

import numpy as np

from arrayproc.errors import ConfigError
from arrayproc.track.manage.tracks import Track
from arrayproc.track.multi.config import split_config
from arrayproc.track.multi.fused import read_fused_array, track_fused

_log = logging.getLogger(__name__)

__all__ = ["fused_rows", "run_fused"]


def fused_rows(tr: Track) -> dict[str, np.ndarray]:
    """A fused track's columns: the Cartesian state and covariance of every history point
    (as the other Cartesian trackers write them, the ownship columns NaN: static arrays),
    ``row`` and ``array`` (the products row and the index of the input that updated it, −1
    coasted) and ``meas_azimuth_deg``."""
    h = tr.arrays()
    n = h["time"].size
    nan = np.full(n, np.nan)
    return {"time": h["time"], "x": h["x"][:, 0], "y": h["x"][:, 1], "vx": h["x"][:, 2],
            "vy": h["x"][:, 3], "cov": h["P"][:, :4, :4], "status": h["status"],
            "side_weight": nan, "row": tr.meta["rows"], "array": tr.meta["array"],
            "meas_azimuth_deg": tr.meta["azimuth_deg"], "own_x": nan, "own_y": nan}


def run_fused(products_paths: Sequence[str], config_path: str, out_path: str,
              progress: bool = False,
              checked: tuple[dict[str, Any], dict[str, Any]] | None = None) -> list[Track]:
    """Track the arrays' azimuths together and write the ``tracks`` group.

    Parameters
    ----------
    products_paths : sequence of str
        One products file per static array (two or more), each naming its recording.
    config_path : str
        Tracker TOML with ``measurements = "fused_bearings"``.
    out_path : str
        Tracks file to write (root attributes ``products`` and ``recording``: the inputs and
        their recordings, one per line; group attributes ``array_x_m``, ``array_y_m``: the
        arrays' positions, indexed by the ``array`` column).
    progress : bool
        One summary line on stderr.
    checked : tuple of dict, optional
        :func:`~arrayproc.track.multi.config.check_multi_config` of ``config_path``.

    Returns
    -------
    list of Track
    """
    from arrayproc.track.multi.run import write_tracks

    cfg, tma_cfg = split_config(config_path) if checked is None else checked
    paths = list(products_paths)
    if len(paths) < 2:
        raise ConfigError(f"{config_path}: tracker.measurements = 'fused_bearings' reads two "
                          f"or more products files, one per static array; {len(paths)} given")
    arrays = [read_fused_array(p, tma_cfg) for p in paths]
    tracks = track_fused(arrays, cfg)
    if progress:
        n_conf = sum(tr.confirmed_at is not None for tr in tracks)
        _log.info(f"{len(tracks)} tracks, {n_conf} confirmed, {len(arrays)} arrays")
    rows = [fused_rows(tr) for tr in tracks]
    sites = np.stack([a["xy"] for a in arrays])
    prods = "\n".join(os.path.abspath(a["products"]) for a in arrays)
    recs = "\n".join(a["recording"] for a in arrays)
    # the tracks' own filter is the EKF of the Cartesian state (no TMA filter per track)
    write_tracks(out_path, tracks, rows, config_path, prods, cfg,
                 dict(tma_cfg, filter="ekf", lr=False),
                 root_attrs={"recording": recs, "products": prods},
                 array_x_m=sites[:, 0], array_y_m=sites[:, 1])
    return tracks
