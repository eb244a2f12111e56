"""``arrayproc tma TRK.h5 -c cross_fix``: one cross-fix solution per confirmed track of a fused
tracks file (``arrayproc track A.h5 B.h5 -c compact_fused``,
:mod:`arrayproc.track.multi.fused`).

Each point of a fused track names the array whose azimuth updated it (``array``, indexing
the group attributes ``array_x_m`` / ``array_y_m``) and that azimuth (``meas_azimuth_deg``),
so the association across the arrays is the tracker's. A confirmed track with
:data:`~.cross_fix_run.MIN_ROWS` or more rows of at least two arrays is solved over its whole
span by :func:`.cross_fix.solve_cross_fix` (thesis eqs. (3.47), (3.53)), every row with
``tma.sigma_bearing_deg``, or (0) each array's σ estimated from its residuals
(:func:`.cross_fix_run.solve_estimated_sigma`).
"""
from __future__ import annotations

import logging
import os

import numpy as np

from arrayproc.errors import FormatError
from arrayproc.io.products import read_products
from arrayproc.io.schema import groups_of_kind
from arrayproc.io.text import as_text

from .cross_fix_run import MIN_ROWS, solve_window
from .result import TmaSolution
from .run import load_tma_config, warn_if_far_from, write_tma

_log = logging.getLogger(__name__)

__all__ = ["is_fused_tracks", "run_cross_fix_fused"]


def _tracks_group(path: str) -> dict | None:
    prod = read_products(path)
    g = groups_of_kind(prod, "tracks")
    return prod[g[0]] if g else None


def is_fused_tracks(path: str) -> bool:
    """Whether a tracks file was written by the fused tracker (``measurements =
    "fused_bearings"``)."""
    g = _tracks_group(path)
    return g is not None and as_text(g["attrs"].get("measurements", "")) == "fused_bearings"


def run_cross_fix_fused(tracks_path: str, config_path: str, output_path: str,
                        progress: bool = False) -> list[tuple[int, TmaSolution]]:
    """Solve each confirmed fused track by cross-fix (module doc); write a ``tma`` group.

    Parameters
    ----------
    tracks_path : str
        Tracks file of the fused tracker.
    config_path : str
        TMA TOML with ``method = "cross_fix"``.
    output_path : str
        Products file to write: one ``tma`` row per solved track (``track_id``).
    progress : bool
        One line per solution on stderr.

    Returns
    -------
    list of (int, TmaSolution)
    """
    cfg = load_tma_config(config_path)
    g = _tracks_group(tracks_path)
    a = g["attrs"]
    sites = np.c_[np.asarray(a["array_x_m"], float), np.asarray(a["array_y_m"], float)]
    ids, arr = np.asarray(g["track_id"]), np.asarray(g["array"])
    conf = np.asarray(g["status"]) == 1
    t, az = np.asarray(g["time"], float), np.asarray(g["meas_azimuth_deg"], float)
    out = []
    for tid in np.unique(ids[conf]):
        m = (ids == tid) & (arr >= 0)
        counts = np.bincount(arr[m], minlength=sites.shape[0])
        if np.sum(counts >= MIN_ROWS) < 2:
            continue
        m &= np.isin(arr, np.flatnonzero(counts >= MIN_ROWS))
        tt, y, site = t[m], np.deg2rad(az[m]), arr[m]
        obs = sites[site]
        w0, w1 = float(tt.min()), float(tt.max())
        sol = solve_window(tt, y, obs, cfg["sigma_bearing_deg"], site, w0, w1)
        out.append((int(tid), sol))
        warn_if_far_from(sol, sites, cfg, f"cross_fix fused track {tid}")
        if progress:
            _log.info(f"tma cross_fix fused track {tid}: x {sol.state[0]:9.1f} y "
                      f"{sol.state[1]:9.1f} m, course {sol.heading_deg:5.1f} deg, speed "
                      f"{sol.speed_mps:5.2f} m/s")
    if not out:
        raise FormatError(f"{tracks_path}: no confirmed track with {MIN_ROWS} or more rows of "
                          "two arrays")
    root = read_products(tracks_path)["/"]
    recs = as_text(root.get("recording", ""))
    write_tma(output_path, [s for _, s in out], recs.splitlines()[0] if recs else "", cfg,
              root_attrs={"tracks": os.path.abspath(tracks_path)},
              track_ids=[i for i, _ in out], tracks=os.path.abspath(tracks_path),
              recordings=recs, array_x_m=sites[:, 0], array_y_m=sites[:, 1])
    return out
