"""Batch cross-fix TMA: bearings from two or more static arrays at known positions.

With bearings from two arrays at distinct known positions the constant-velocity state is
observable without own-ship manoeuvre and without a speed prior: each pair of simultaneous
bearings is a cross-fix.  The ML estimate minimises the σ-weighted bearing residuals of
thesis eq. (3.47) over all rows, each row with its own array position and σ; the CRLB is the
inverse of the bearings-only FIM of eq. (3.53) with per-row σ (:func:`.fim.bo_fim`).
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from arrayproc.geo.rays import ray_intersection

from .bo_tma import _wrap, bearing_model
from .fim import bo_fim, bo_jacobian
from .result import TmaSolution, end_value, finish_solution


def _initial_state(t: np.ndarray, y: np.ndarray, obs: np.ndarray, t0: float,
                   t1: float) -> np.ndarray:
    """CV state at ``t0`` from the cross-fixes of the first two arrays at ``t0`` and ``t1``,
    each array's bearing there from a straight line through its rows nearest that end
    (:func:`.result.end_value`: one noisy row would turn the near-parallel rays of a distant
    target into a fix far beyond it)."""
    sites = np.unique(obs, axis=0)
    fixes = []
    for at in (t0, t1):
        b = []
        for s in sites[:2]:
            m = np.all(obs == s, axis=1)
            b.append(end_value(t[m], y[m], at, n_fit=max(10, int(m.sum()) // 10))[0])
        fixes.append(ray_intersection(sites[0], b[0], sites[1], b[1]))
    if fixes[0] is None or fixes[1] is None:
        c = sites.mean(axis=0)
        return np.array([c[0] + 1000.0, c[1] + 1000.0, 0.0, 0.0])
    v = (fixes[1] - fixes[0]) / max(t1 - t0, 1e-9)
    return np.concatenate([fixes[0], v])


def solve_cross_fix(times: np.ndarray, bearings_rad: np.ndarray, array_xy: np.ndarray,
                    sigma_rad: float | np.ndarray, *, t0: float | None = None,
                    t1: float | None = None, x0: np.ndarray | None = None) -> TmaSolution:
    """ML cross-fix TMA of static arrays with no speed prior (eqs. (3.47), (3.53)).

    Parameters
    ----------
    times : (B,) array_like
        Bearing times (s), rows of all arrays together.
    bearings_rad : (B,) array_like
        Bearings, rad clockwise from north.
    array_xy : (B, 2) array_like
        Position of the array that measured each row (m); at least two distinct positions.
    sigma_rad : float or (B,) array_like
        Bearing standard deviation per row (rad).
    t0, t1 : float, optional
        Window start (the state's time) and end (s).
    x0 : (4,) array_like, optional
        Starting state of the local fit (default: the cross-fixes at the window's ends).

    Returns
    -------
    TmaSolution
        ``method = "cross_fix"``.
    """
    t = np.asarray(times, float).reshape(-1)
    y = np.asarray(bearings_rad, float).reshape(-1)
    obs = np.asarray(array_xy, float).reshape(t.size, 2)
    sig = np.broadcast_to(np.asarray(sigma_rad, float), t.shape).copy()
    if np.unique(obs, axis=0).shape[0] < 2:
        raise ValueError("cross-fix TMA needs bearings from at least two array positions")
    order = np.argsort(t, kind="stable")
    t, y, obs, sig = t[order], y[order], obs[order], sig[order]
    t0 = float(t[0] if t0 is None else t0)
    t1 = float(t[-1] if t1 is None else t1)
    tau = t - t0
    w = 1.0 / sig

    def res(x: np.ndarray) -> np.ndarray:
        return w * _wrap(y - bearing_model(x, tau, obs))

    def jac(x: np.ndarray) -> np.ndarray:
        return -w[:, None] * bo_jacobian(x, tau, obs)

    x0 = _initial_state(t, y, obs, t0, t1) if x0 is None else np.asarray(x0, float)
    x = least_squares(res, x0, jac=jac, method="lm", xtol=1e-12, ftol=1e-12).x
    r = res(x)
    sol = finish_solution("cross_fix", t0, t1, x, r, jac(x), bo_fim(x, tau, obs, sig),
                          np.unique(obs, axis=0)[0], bearing_model(x, tau, obs),
                          n_used=t.size)
    sol.rss = float(np.sum((r / w) ** 2))
    return sol
