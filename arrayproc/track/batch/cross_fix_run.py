"""``arrayproc tma A.h5 B.h5 … -c cross_fix``: cross-fix TMA of two or more static arrays.

Each products file holds one array's ``bearings`` group (one true bearing per row: a
volumetric/planar array's ``azimuth_deg``, or a line array's bearing on the side
``tma.side`` names) and names its recording in the root attribute ``source``; that
recording's ``/nav`` and ``/array`` place the array: its phase centre (mean element
position) at the rows' times, as ``method = "compact"`` places it. The arrays are static
(their phase centre moves less than :data:`STATIC_TOLERANCE_M` over the rows) and their
``/nav`` positions share one local frame (x east, y north, m, from one origin). A products
file whose recording is missing, or has no ``/nav`` (the array's position unknown), is
refused.

One solution per window (``tma.window``, ``tma.step`` over the union of the arrays' rows;
0: the whole span): the ML estimate of thesis eq. (3.47) over every array's rows in the
window, each row with its array's position and σ, and the CRLB of eq. (3.53)
(:func:`.cross_fix.solve_cross_fix`); a window is solved when at least two arrays have five or
more rows in it. The bearing σ is ``tma.sigma_bearing_deg`` for every row, or (0) estimated
for each array from its residuals (:func:`solve_estimated_sigma`).

Association: each file's rows are taken as one target's (the strongest row per time, as for
one products file, after ``tma.cone_gate``): the rows of one vessel in a window, e.g. a
window or gate chosen around one target. Several targets: two arrays' tracks files, paired
by :mod:`.cross_fix_tracks`.
"""
from __future__ import annotations

import logging
import os
from typing import Any

import numpy as np

from arrayproc.config import resolve_beside
from arrayproc.errors import ConfigError, FormatError
from arrayproc.io.recording import Recording

from .bo_tma import _wrap, bearing_model
from .cross_fix import solve_cross_fix
from .result import TmaSolution
from .run import (
    _windows,
    load_tma_config,
    read_measurements,
    true_bearings,
    warn_if_far_from,
    write_tma,
)

_log = logging.getLogger(__name__)

__all__ = ["STATIC_TOLERANCE_M", "array_position", "read_array", "solve_estimated_sigma",
           "run_cross_fix"]

#: the largest distance (m) an array's phase centre may move from its mean over the rows read
#: for the array to count as static (a mooring's swing; a moving array: ``bearings``)
STATIC_TOLERANCE_M = 10.0
#: rows an array needs in a window to take part in its solution
MIN_ROWS = 5


def read_array(products_path: str, cfg: dict[str, Any]) -> dict[str, Any]:
    """One array's bearings and position (module doc).

    Parameters
    ----------
    products_path : str
        Products file of one array (a ``bearings`` group; root attribute ``source``).
    cfg : dict
        Checked TMA configuration (``group``, ``cone_gate``, ``side``).

    Returns
    -------
    dict
        ``time`` (s), ``bearing`` (rad, clockwise from north), ``xy`` (2,) the phase
        centre's mean position (m), ``recording``, ``products`` and ``group``.
    """
    meas = read_measurements(products_path, dict(cfg, method="cross_fix"))
    rec_path = named_recording(products_path, meas["source"])
    t = meas["time"]
    return {"time": t, "bearing": true_bearings(meas, np.ones(t.size, bool), cfg),
            "xy": array_position(products_path, rec_path, t), "recording": rec_path,
            "products": products_path, "group": meas["group"]}


def named_recording(where: str, source: str) -> str:
    """The recording a products or tracks file names (its ``source``), resolved beside the
    file; FormatError naming ``where`` when it names none or the recording does not exist
    (the array's position is then unknown)."""
    if not source:
        raise FormatError(f"{where}: names no recording (root attribute 'source'): the "
                          "array's position is unknown")
    rec_path = resolve_beside(source, where)
    if not os.path.exists(rec_path):
        raise FormatError(f"{where}: its recording {rec_path} does not exist: the array's "
                          "position is unknown")
    return rec_path


def solve_window(t: np.ndarray, y: np.ndarray, obs: np.ndarray, sigma_deg: float,
                 site: np.ndarray, t0: float, t1: float) -> TmaSolution:
    """The cross-fix of one window's rows: with the configured σ (deg) when it is > 0, else
    with each array's σ estimated (:func:`solve_estimated_sigma`)."""
    if sigma_deg > 0:
        return solve_cross_fix(t, y, obs, np.deg2rad(sigma_deg), t0=t0, t1=t1)
    return solve_estimated_sigma(t, y, obs, site, t0, t1)


def array_position(where: str, rec_path: str, times: np.ndarray) -> np.ndarray:
    """A static array's position (2,) m: the mean of its phase centre (mean element
    position, ``/nav`` and ``/array``) at ``times``; FormatError (naming ``where``) when the
    recording has no ``/nav`` or the centre moves more than :data:`STATIC_TOLERANCE_M`."""
    with Recording(rec_path) as rec:
        if not rec.has("nav"):
            raise FormatError(f"{where}: its recording {rec_path} has no /nav: the "
                              "array's position is unknown")
        centre = np.stack([p.elements[:, :2].mean(0) for p in rec.poses(times)])
    xy = centre.mean(0)
    drift = float(np.max(np.hypot(*(centre - xy).T)))
    if drift > STATIC_TOLERANCE_M:
        raise FormatError(f"{where}: the array moves {drift:.3g} m over the rows "
                          f"(more than {STATIC_TOLERANCE_M:g} m): cross_fix is for static "
                          "arrays (a moving array: method = 'bearings')")
    return xy


def solve_estimated_sigma(t: np.ndarray, y: np.ndarray, obs: np.ndarray, site: np.ndarray,
                          t0: float, t1: float, n_iter: int = 2) -> TmaSolution:
    """Cross-fix solution with each array's bearing σ estimated from its residuals.

    A first fit with one σ for every row (the ML estimate for equal σ); then, ``n_iter``
    times, each array's σ² is the sum of its squared residuals over its share of the degrees
    of freedom, ``σ̂ₐ² = Σ rₐ² / (nₐ (1 − 4/N))`` (``N`` rows in all), and the fit is repeated
    with those σ (eq. (3.47) weighted per row), from the previous fit's state; the CRLB
    (eq. (3.53)) is the one at the last σ̂.

    Parameters
    ----------
    t, y : (N,) ndarray
        Times (s) and bearings (rad).
    obs : (N, 2) ndarray
        Each row's array position (m).
    site : (N,) ndarray of int
        Each row's array index.
    t0, t1 : float
        Window start (the state's time) and end (s).
    n_iter : int
        Re-estimations of the σ.

    Returns
    -------
    TmaSolution
    """
    sig = np.full(t.size, np.deg2rad(1.0))
    sol = solve_cross_fix(t, y, obs, sig, t0=t0, t1=t1)
    dof = 1.0 - 4.0 / max(t.size, 5)
    for _ in range(n_iter):
        r = _wrap(y - bearing_model(sol.state, t - t0, obs))
        for a in np.unique(site):
            m = site == a
            sig[m] = max(float(np.sqrt(np.sum(r[m] ** 2) / (m.sum() * dof))), 1e-9)
        sol = solve_cross_fix(t, y, obs, sig, t0=t0, t1=t1, x0=sol.state)
    return sol


def _window_rows(arrays: list[dict[str, Any]], w0: float, w1: float
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    """Times, bearings, positions and array indices of the window's rows of the arrays with
    :data:`MIN_ROWS` or more rows in it; None unless two arrays have."""
    parts = []
    for k, a in enumerate(arrays):
        sel = (a["time"] >= w0) & (a["time"] <= w1)
        if sel.sum() >= MIN_ROWS:
            parts.append((a["time"][sel], a["bearing"][sel], k))
    if len(parts) < 2:
        return None
    t = np.concatenate([p[0] for p in parts])
    y = np.concatenate([p[1] for p in parts])
    site = np.concatenate([np.full(p[0].size, p[2]) for p in parts])
    obs = np.stack([arrays[k]["xy"] for k in site])
    return t, y, obs, site


def run_cross_fix(products_paths: list[str], config_path: str, output_path: str,
                  progress: bool = False) -> list[TmaSolution]:
    """Cross-fix TMA over the bearings of two or more arrays; write a ``tma`` group.

    Parameters
    ----------
    products_paths : list of str
        One products file per array (module doc).
    config_path : str
        TMA TOML with ``method = "cross_fix"`` (``arrayproc/data/tma/cross_fix.toml``).
    output_path : str
        Products file to write (one ``tma`` group named ``tma``, ``method = "cross_fix"``;
        attributes ``products`` and ``recording``: the arrays' files, one per line;
        ``array_x_m``, ``array_y_m``: their positions).
    progress : bool
        One line per solution on stderr.

    Returns
    -------
    list of TmaSolution
    """
    cfg = load_tma_config(config_path)
    if cfg["method"] != "cross_fix":
        raise ConfigError(f"{config_path}: tma.method = {cfg['method']!r} reads one products "
                          f"file; {len(products_paths)} were given (several: method = "
                          "'cross_fix')")
    if len(products_paths) < 2:
        raise ConfigError(f"{config_path}: tma.method = 'cross_fix' reads two or more products "
                          f"files, one per array; {len(products_paths)} given")
    if cfg["recording"]:
        raise ConfigError(f"{config_path}: tma.recording does not apply to method = "
                          "'cross_fix' (each products file's own recording places its array)")
    arrays = [read_array(p, cfg) for p in products_paths]
    sites = np.stack([a["xy"] for a in arrays])
    for i in range(len(arrays)):
        for j in range(i):
            if np.hypot(*(sites[i] - sites[j])) < 1.0:
                raise FormatError(f"{arrays[i]['products']} and {arrays[j]['products']}: the "
                                  "arrays are at the same position (within 1 m): no cross-fix")
    t_all = np.sort(np.concatenate([a["time"] for a in arrays]))
    sols = []
    for w0, w1 in _windows(t_all, cfg["window"], cfg["step"]):
        rows = _window_rows(arrays, w0, w1)
        if rows is None:
            continue
        t, y, obs, site = rows
        try:
            sol = solve_window(t, y, obs, cfg["sigma_bearing_deg"], site, w0, w1)
        except (ValueError, np.linalg.LinAlgError) as e:
            raise FormatError(f"window [{w0:g}, {w1:g}] s: {e}") from None
        sols.append(sol)
        warn_if_far_from(sol, sites, cfg, f"cross_fix window [{w0:g}, {w1:g}] s")
        if progress:
            _log.info(f"tma cross_fix [{w0:8.1f}, {w1:8.1f}] s: x {sol.state[0]:9.1f} y "
                      f"{sol.state[1]:9.1f} m, course {sol.heading_deg:5.1f} deg, speed "
                      f"{sol.speed_mps:5.2f} m/s, range σ {sol.range_sigma:8.1f} m")
    if not sols:
        raise FormatError(f"{', '.join(products_paths)}: no window in which two arrays have "
                          f"{MIN_ROWS} or more bearing rows")
    prods = [os.path.abspath(a["products"]) for a in arrays]
    recs = [a["recording"] for a in arrays]
    write_tma(output_path, sols, recs[0], cfg, root_attrs={"products": "\n".join(prods)},
              measurements=",".join(a["group"] for a in arrays), products="\n".join(prods),
              recordings="\n".join(recs), array_x_m=sites[:, 0], array_y_m=sites[:, 1])
    return sols
