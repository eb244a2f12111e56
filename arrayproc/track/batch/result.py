"""The result of one batch TMA solution (one row of the products ``tma`` kind, docs/formats.md)
and the global-then-local least-squares search the three methods share.

The search is the thesis's (section 3.3.1: differential evolution, "much better results" than a
local simplex) followed by a Gauss-Newton/Levenberg-Marquardt polish of the same cost:
differential evolution (:func:`.evolution.evolve`, scipy's ``best1bin`` with deferred updating,
each generation in whole-population array operations) over a population-vectorised objective, then
``scipy.optimize.leastsq`` (MINPACK) on the weighted residual vector from the best member.

The global step searches the bearings and ranges at the window's start and end
(:class:`PolarSearch`) rather than a Cartesian box: the likelihood's basin is a thin valley
around the measured bearing history (a fraction of a degree wide for 128-hydrophone delays),
which a population spread over a ±20 km box almost never samples (measured: it settled on the
box edge, the plane-wave limit); the bearings are bounded around straight lines fitted to the
first and last bearings, the ranges span the search interval on a log scale. The state the estimator
returns is still the thesis's (x, y, ẋ, ẏ) at the window start.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import leastsq

from .evolution import evolve
from .fim import condition_number, crlb_from_fim, range_sigma

__all__ = ["TmaSolution", "end_value", "PolarSearch", "global_then_local", "finish_solution"]


@dataclass
class TmaSolution:
    """One batch TMA solution (products ``tma`` row).

    Attributes
    ----------
    t0, t1 : float
        Window start and end (s); the state refers to ``t0``.
    method : str
        ``bearings``, ``delays`` or ``compact``.
    state : (4,) ndarray
        [x, y, vx, vy] at ``t0`` (m, m/s).
    cov : (4, 4) ndarray
        ``s² (GᵀWG)⁻¹`` at the estimate with the residual variance factor ``s²`` (the
        estimator's covariance when σ is unknown); NaN where not positive definite.
    crlb : (4, 4) ndarray
        Inverse FIM at the estimate with the given σ (thesis eq. (3.53)); NaN where the FIM is
        not positive definite.
    cost : float
        Weighted sum of squared residuals at the estimate (``−2ℓ`` up to a constant).
    fim_cond : float
        FIM condition number (thesis eq. (3.54)); ``inf`` when singular.
    range_sigma : float
        Range standard deviation at ``t0`` (thesis eq. (3.55)), m; NaN when blanked.
    n_used, n_rejected : int
        Measurements used and rejected as outliers.
    side : str
        Mirror hypothesis kept for a line array (``port``/``starboard``), else ``""``.
    cost_other : float
        Cost of the other mirror hypothesis (NaN when not solved).
    observer : (2,) ndarray
        Observer (array) position at ``t0`` (m).
    fitted : ndarray
        Model values at the estimate for the measurements used (rad or s).
    rss : float
        Unweighted sum of squared residuals (rad² or s²), NaN when not computed.
    correlation : float
        Within-snapshot correlation of the delays used (``delays``; NaN otherwise).
    tau_s, tau_sigma_s : float
        ``compact``: the bearing errors' correlation time used (s) and, when it was estimated
        from the residuals (:mod:`.correlation`), its standard error (NaN otherwise).
    mirror : TmaSolution or None
        A line array's mirror solution (both sides flipped; :func:`.bo_tma.solve_cone`).
    """

    t0: float
    t1: float
    method: str
    state: np.ndarray
    cov: np.ndarray
    crlb: np.ndarray
    cost: float
    fim_cond: float
    range_sigma: float
    n_used: int
    n_rejected: int = 0
    side: str = ""
    cost_other: float = float("nan")
    observer: np.ndarray = field(default_factory=lambda: np.zeros(2))
    fitted: np.ndarray = field(default_factory=lambda: np.zeros(0))
    rss: float = float("nan")
    correlation: float = float("nan")
    tau_s: float = float("nan")
    tau_sigma_s: float = float("nan")
    mirror: TmaSolution | None = None

    @property
    def heading_deg(self) -> float:
        """Course of the estimate, deg clockwise from north in [0, 360)."""
        return float(np.degrees(np.arctan2(self.state[2], self.state[3])) % 360.0)

    @property
    def speed_mps(self) -> float:
        """Speed of the estimate, m/s."""
        return float(np.hypot(self.state[2], self.state[3]))


def end_value(times: np.ndarray, values: np.ndarray, at: float, n_fit: int = 10
              ) -> tuple[float, float]:
    """Value of a sequence at one end of its window, from a straight line through the
    ``n_fit`` samples nearest ``at``.

    Parameters
    ----------
    times, values : (B,) array_like
        s and e.g. rad (unwrapped here); NaN samples are ignored.
    at : float
        Time (s) at which to evaluate.
    n_fit : int
        Samples used.

    Returns
    -------
    value : float
        The fitted value at ``at``.
    scale : float
        Robust scale of the residues (1.4826 × median absolute residue).
    """
    t = np.asarray(times, float)
    v = np.asarray(values, float)
    ok = np.isfinite(v) & np.isfinite(t)
    t, v = t[ok], np.unwrap(v[ok])
    idx = np.argsort(np.abs(t - at))[:max(2, n_fit)]
    if idx.size < 2:
        return float(v[idx[0]]), 0.0
    coef = np.polyfit(t[idx] - at, v[idx], 1)
    res = v[idx] - np.polyval(coef, t[idx] - at)
    return float(coef[1]), float(1.4826 * np.median(np.abs(res)))


class PolarSearch:
    """Coordinates of the global search: bearings and ranges at the window's start and end.

    The source is at bearing ``β0 = c0[i0] + δ0`` and range ``r0`` from the observer
    position ``o0`` at the window start and at ``(β1 = c1[i1] + δ1, r1)`` from ``o1`` at its
    end, ``duration`` later; constant velocity between (thesis eq. (3.41)). ``c0`` and ``c1``
    are the candidate bearings at the two ends (one, or the two mirror bearings of a line
    array, whose choice ``i0``, ``i1`` is then a search coordinate too); ``δ`` spans
    ``±margin``; ``ln r`` spans ``[ln min_range, ln max_range]``.
    """

    def __init__(self, c0: np.ndarray, c1: np.ndarray, margin: float, min_range_m: float,
                 max_range_m: float, duration: float, o0: np.ndarray, o1: np.ndarray) -> None:
        self.c0 = np.atleast_1d(np.asarray(c0, float))
        self.c1 = np.atleast_1d(np.asarray(c1, float))
        self.duration = float(duration)
        self.o0 = np.asarray(o0, float)
        self.o1 = np.asarray(o1, float)
        lr = (float(np.log(min_range_m)), float(np.log(max_range_m)))
        self.bounds = [(-margin, margin), (-margin, margin), lr, lr]
        for c in (self.c0, self.c1):
            if c.size > 1:
                self.bounds.append((0.0, float(c.size)))

    def to_state(self, q: np.ndarray) -> np.ndarray:
        """States [x, y, vx, vy] (4, P) from search coordinates (n_par, P)."""
        q = np.asarray(q, float).reshape(len(self.bounds), -1)
        k = 4
        b0 = self.c0[0] + q[0]
        b1 = self.c1[0] + q[1]
        if self.c0.size > 1:
            b0 = self.c0[np.minimum(q[k].astype(np.intp), self.c0.size - 1)] + q[0]
            k += 1
        if self.c1.size > 1:
            b1 = self.c1[np.minimum(q[k].astype(np.intp), self.c1.size - 1)] + q[1]
        r0, r1 = np.exp(q[2]), np.exp(q[3])
        out = np.empty((4, q.shape[1]))
        out[0] = self.o0[0] + r0 * np.sin(b0)
        out[1] = self.o0[1] + r0 * np.cos(b0)
        out[2] = (self.o1[0] + r1 * np.sin(b1) - out[0]) / self.duration
        out[3] = (self.o1[1] + r1 * np.cos(b1) - out[1]) / self.duration
        return out


def global_then_local(pop_cost: Callable[[np.ndarray], np.ndarray],
                      residuals: Callable[[np.ndarray], np.ndarray],
                      jacobian: Callable[[np.ndarray], np.ndarray],
                      bounds: list[tuple[float, float]],
                      to_state: Callable[[np.ndarray], np.ndarray],
                      seed: int | np.random.Generator, popsize: int = 20, maxiter: int = 400,
                      tol: float = 1e-3) -> np.ndarray:
    """Differential evolution on ``pop_cost`` then a least-squares polish of ``residuals``.

    Parameters
    ----------
    pop_cost : callable
        ``(4, P) states -> (P,)`` cost of a population of states (vectorised, numba).
    residuals, jacobian : callable
        Weighted residual vector and its Jacobian at one state.
    bounds : list of (lo, hi)
        Search box of the global step, in the coordinates ``to_state`` maps from.
    to_state : callable
        ``(n_par, P) -> (4, P)``: search coordinates to states (:meth:`PolarSearch.to_state`).
    seed : int or Generator
        Seed of the differential evolution.
    popsize, maxiter, tol : int, int, float
        Differential-evolution settings (:func:`.evolution.evolve`).

    Returns
    -------
    (4,) ndarray
        The polished state.
    """
    n = len(bounds)
    de = evolve(lambda q: pop_cost(to_state(q)), bounds, seed, popsize=popsize,
                maxiter=maxiter, tol=tol, mutation=(0.5, 1.0), recombination=0.9)
    x0 = to_state(de.x.reshape(n, 1))[:, 0]
    # MINPACK's lmder with its Jacobian column scaling, the same iterations as
    # least_squares(method="lm", x_scale="jac") without that wrapper's ~20 ms per call
    return leastsq(residuals, x0, Dfun=jacobian, xtol=1e-12, ftol=1e-12, gtol=1e-12,
                   maxfev=200)[0]


def finish_solution(method: str, t0: float, t1: float, state: np.ndarray, wres: np.ndarray,
                    wjac: np.ndarray, fim: np.ndarray, observer: np.ndarray, fitted: np.ndarray,
                    n_used: int, n_rejected: int = 0, n_residuals: int | None = None
                    ) -> TmaSolution:
    """Assemble a :class:`TmaSolution` from the weighted residuals and Jacobian at the estimate.

    ``cov = s² (wjacᵀ wjac)⁻¹`` with ``s² = Σ wres² / (n_res − n_par)`` (``n_res`` the
    residuals, ``n_residuals`` when given, else ``n_used``; ``n_par`` the state's size);
    ``crlb = fim⁻¹``; both blanked where not positive definite.
    """
    n = int(n_used)
    cost = float(np.sum(wres**2))
    s2 = cost / max((n if n_residuals is None else int(n_residuals)) - state.size, 1)
    gn, _ = crlb_from_fim(wjac.T @ wjac)
    crlb, _ = crlb_from_fim(fim)
    return TmaSolution(
        t0=float(t0), t1=float(t1), method=method, state=np.asarray(state, float),
        cov=s2 * gn, crlb=crlb, cost=cost, fim_cond=float(condition_number(fim)),
        range_sigma=float(range_sigma(np.asarray(state[:2]) - observer, crlb)),
        n_used=int(n), n_rejected=int(n_rejected), observer=np.asarray(observer, float),
        fitted=np.asarray(fitted, float))
