"""Maximum-likelihood correlation time of a track's bearing errors, and the compact-array TMA
refitted with it.

The compact-array paper models the bearing errors as exponentially correlated,
``C_ij = σ² exp(−|t_i − t_j|/τ)`` (its eq. (4) with a first-order Gauss-Markov error), and
estimates τ from the residuals of a first fit. The Ornstein-Uhlenbeck error is Markov
(:func:`.fim.innovation_coefficients`): with ``φ_b = exp(−(t_b − t_{b−1})/τ)``::

    e_b = φ_b e_{b−1} + σ √(1 − φ_b²) ξ_b,     ξ_b ~ N(0, 1),   e_0 ~ N(0, σ²)          (C1)

so the exact Gaussian log-likelihood of residuals r (any, irregular, sampling) is, in O(N)::

    ℓ(σ², τ) = −½ Σ_b [ log(2π σ² w_b) + (r_b − φ_b r_{b−1})² / (σ² w_b) ],
    w_b = 1 − φ_b²   (w_0 = 1, φ_0 = 0)                                                (C2)

σ² is profiled out in closed form, ``σ̂²(τ) = (1/N) Σ_b (r_b − φ_b r_{b−1})² / w_b``, which
leaves the profile log-likelihood of τ alone::

    ℓ_p(τ) = −(N/2) (log 2π σ̂²(τ) + 1) − ½ Σ_b log w_b                                (C3)

τ̂ maximises ℓ_p over log τ (a log-spaced grid, then a bounded Brent step around the best
node); its standard error is that of the profile, ``se(log τ) = (−∂²ℓ_p/∂(log τ)²)^{−1/2}``
at τ̂ (central differences), and ``se(τ) = τ̂ se(log τ)`` (the delta method). τ is searched in
[δ_min/4, 20 T] (δ_min the shortest sampling step, T the span); an estimate on a bound is
returned with ``at_bound`` set (white residuals give the lower one).

The residuals of a fit are not quite the errors: the three fitted parameters absorb the
slowest components, so τ̂ is biased low when τ is not small against the window (a few per
cent for τ = T/30; see docs/validation/compact.md for the measured estimates).

:func:`solve_compact_estimated` is the paper's procedure: a first fit with the configured
(or zero) τ, τ̂ from its residuals, a refit with τ̂; the solution carries ``tau_s`` and
``tau_sigma_s``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize_scalar

from .compact import solve_compact
from .result import TmaSolution

__all__ = ["CorrelationEstimate", "profile_loglik", "estimate_correlation_time",
           "solve_compact_estimated"]


@dataclass
class CorrelationEstimate:
    """The ML correlation time of a residual series.

    Attributes
    ----------
    tau_s : float
        τ̂ (s).
    tau_sigma_s : float
        Its standard error (s), from the profile likelihood's curvature; ``inf`` when the
        curvature is not negative (a flat profile).
    sigma : float
        σ̂ at τ̂ (the residuals' units).
    loglik : float
        ℓ_p(τ̂) (eq. C3).
    at_bound : bool
        τ̂ lies on a bound of the search interval.
    """

    tau_s: float
    tau_sigma_s: float
    sigma: float
    loglik: float
    at_bound: bool


def _prepare(times: np.ndarray, residuals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    t = np.asarray(times, float).reshape(-1)
    r = np.asarray(residuals, float).reshape(-1)
    if t.size != r.size:
        raise ValueError(f"{t.size} times but {r.size} residuals")
    ok = np.isfinite(t) & np.isfinite(r)
    t, r = t[ok], r[ok]
    order = np.argsort(t, kind="stable")
    t, r = t[order], r[order]
    if t.size < 3:
        raise ValueError(f"the correlation time needs at least 3 residuals, {t.size} given")
    if np.any(np.diff(t) <= 0):
        raise ValueError("the residuals' times must be distinct")
    return t, r


def _profile(tau: float, dt: np.ndarray, r: np.ndarray) -> tuple[float, float]:
    """(ℓ_p(τ), σ̂²(τ)) of eq. (C3) for steps dt (N−1,) and residuals r (N,)."""
    phi = np.exp(-dt / tau)
    w = -np.expm1(-2.0 * dt / tau)  # 1 − φ², accurate for small dt/τ
    e = r[1:] - phi * r[:-1]
    n = r.size
    s2 = (r[0] ** 2 + float(np.sum(e * e / w))) / n
    if not s2 > 0:
        return -math.inf, 0.0
    ll = -0.5 * n * (math.log(2.0 * math.pi * s2) + 1.0) - 0.5 * float(np.sum(np.log(w)))
    return ll, s2


def profile_loglik(times: np.ndarray, residuals: np.ndarray, tau_s: float) -> float:
    """Profile log-likelihood ℓ_p(τ) of eq. (C3) (σ² at its ML value for this τ).

    Parameters
    ----------
    times : (N,) array_like
        Distinct times (s), any order (sorted here).
    residuals : (N,) array_like
        The residuals at those times.
    tau_s : float
        τ (s), > 0.

    Returns
    -------
    float
    """
    t, r = _prepare(times, residuals)
    return _profile(float(tau_s), np.diff(t), r)[0]


def estimate_correlation_time(times: np.ndarray, residuals: np.ndarray,
                              bounds: tuple[float, float] | None = None,
                              n_grid: int = 48) -> CorrelationEstimate:
    """Maximum-likelihood τ of exponentially correlated residuals (eqs. C1-C3).

    Parameters
    ----------
    times : (N,) array_like
        Distinct sample times (s), N ≥ 3.
    residuals : (N,) array_like
        Residuals of a fit (NaN entries are dropped).
    bounds : (float, float), optional
        Search interval of τ (s); default [δ_min/4, 20 T].
    n_grid : int
        Log-spaced nodes of the coarse search.

    Returns
    -------
    CorrelationEstimate
    """
    t, r = _prepare(times, residuals)
    dt = np.diff(t)
    lo, hi = bounds if bounds is not None else (float(dt.min()) / 4.0,
                                                 20.0 * float(t[-1] - t[0]))
    if not 0 < lo < hi:
        raise ValueError(f"bounds must satisfy 0 < lo < hi, got ({lo}, {hi})")
    grid = np.linspace(math.log(lo), math.log(hi), n_grid)
    ll = np.array([_profile(math.exp(g), dt, r)[0] for g in grid])
    k = int(np.argmax(ll))
    a, b = grid[max(k - 1, 0)], grid[min(k + 1, n_grid - 1)]
    res = minimize_scalar(lambda g: -_profile(math.exp(g), dt, r)[0], bounds=(a, b),
                          method="bounded", options={"xatol": 1e-6})
    g = float(res.x) if -res.fun >= ll[k] else float(grid[k])
    g = min(max(g, grid[0]), grid[-1])
    best, s2 = _profile(math.exp(g), dt, r)
    at_bound = g - grid[0] < 1e-3 or grid[-1] - g < 1e-3
    h = 0.02
    d2 = (_profile(math.exp(g + h), dt, r)[0] - 2.0 * best
          + _profile(math.exp(g - h), dt, r)[0]) / (h * h)
    tau = math.exp(g)
    se = tau / math.sqrt(-d2) if d2 < 0 else math.inf
    return CorrelationEstimate(tau, se, math.sqrt(s2), best, bool(at_bound))


def solve_compact_estimated(times: np.ndarray, bearings_rad: np.ndarray,
                            array_xy: np.ndarray, sigma_rad: float | None, *,
                            correlation_s: float = 0.0, iterations: int = 2,
                            **kw: object) -> TmaSolution:
    """Compact-array TMA with the correlation time estimated from its own residuals.

    A first fit (:func:`.compact.solve_compact`) with ``correlation_s``, then ``iterations``
    times: τ̂ from the wrapped residuals ``α̂ − α(θ̂)`` (:func:`estimate_correlation_time`)
    and a refit with it.

    Parameters
    ----------
    times, bearings_rad, array_xy, sigma_rad
        As :func:`.compact.solve_compact`.
    correlation_s : float
        τ of the first fit (s); 0: independent errors.
    iterations : int
        Estimate-and-refit passes (≥ 1).
    **kw
        The other keywords of :func:`.compact.solve_compact`.

    Returns
    -------
    TmaSolution
        The last refit, with ``tau_s`` (τ̂ used) and ``tau_sigma_s`` (its standard error).
    """
    t = np.asarray(times, float).reshape(-1)
    y = np.asarray(bearings_rad, float).reshape(-1)
    ok = np.isfinite(y)
    sol = solve_compact(t, y, array_xy, sigma_rad, correlation_s=correlation_s, **kw)
    est = None
    for _ in range(max(int(iterations), 1)):
        resid = np.angle(np.exp(1j * (y[ok] - sol.fitted)))
        est = estimate_correlation_time(t[ok], resid)
        sol = solve_compact(t, y, array_xy, sigma_rad, correlation_s=est.tau_s, **kw)
    sol.tau_s = est.tau_s
    sol.tau_sigma_s = est.tau_sigma_s
    return sol
