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

The bearings of a peak picker also scatter from scan to scan (white noise of σ_w): the
residuals are then ``r_b = e_b + v_b``, ``v_b ~ N(0, σ_w²)`` (eq. C4), whose exponential fit
alone gives a τ far too short (measured: 2.6 s for τ = 20 s with σ_w = σ). With ``white``
the likelihood of (C4) is that of the Kalman filter's innovations of the AR(1) state (C1)
observed in white noise, the total variance s² = σ² + σ_w² profiled out as above and the
share ρ = σ²/s² a second parameter, maximised over (log τ, logit ρ) (a grid, then
Nelder-Mead); se(log τ) from the inverse Hessian there (the curvature in log τ alone when ρ̂
lies on its bound).

The residuals of a fit are not quite the errors: the fitted parameters absorb the slowest
components, so τ̂ from them is biased low (measured on the compact TMA: 20 s came back as
13-15 s over 330 s windows). Given the fit's Jacobian G (N × p) at its solution, the
restricted (REML, Patterson & Thompson) likelihood of the residuals counts what the fit
took::

    ℓ_R = −((N − p)/2) (log 2π ŝ² + 1) − ½ log det K − ½ log det(Gᵀ K⁻¹ G),
    ŝ² = |P⊥ K^{−1/2} r|² / (N − p)                                                    (C5)

(K the unit-variance correlation of (C1) or (C4), K^{−1/2} applied by the Kalman
innovations of every column, P⊥ the projection off the whitened G), maximised as above.

:func:`solve_compact_estimated` is the paper's procedure: a first fit with the configured
(or zero) τ, τ̂ from its residuals (by default the restricted likelihood (C5) of the model
(C4)), a refit with τ̂, twice; the solution carries ``tau_s`` and ``tau_sigma_s``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize_scalar

from .compact import solve_compact
from .fim import compact_jacobian
from .result import TmaSolution

__all__ = ["CorrelationEstimate", "profile_loglik", "estimate_correlation_time",
           "correlated_whitener", "window_bounds", "solve_compact_estimated"]


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
    white_sigma : float
        σ̂ of the white part (eq. C4); 0 for the exponential model alone.
    """

    tau_s: float
    tau_sigma_s: float
    sigma: float
    loglik: float
    at_bound: bool
    white_sigma: float = 0.0


def _prepare(times: np.ndarray, residuals: np.ndarray, design: np.ndarray | None = None
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    t = np.asarray(times, float).reshape(-1)
    r = np.asarray(residuals, float).reshape(-1)
    if t.size != r.size:
        raise ValueError(f"{t.size} times but {r.size} residuals")
    g = None if design is None else np.asarray(design, float).reshape(t.size, -1)
    ok = np.isfinite(t) & np.isfinite(r)
    if g is not None:
        ok &= np.all(np.isfinite(g), axis=1)
    order = np.flatnonzero(ok)[np.argsort(t[ok], kind="stable")]
    t, r = t[order], r[order]
    g = None if g is None else g[order]
    if t.size < 3 + (0 if g is None else g.shape[1]):
        raise ValueError(f"the correlation time needs more residuals than {t.size}")
    if np.any(np.diff(t) <= 0):
        raise ValueError("the residuals' times must be distinct")
    return t, r, g


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
    t, r, _ = _prepare(times, residuals)
    return _profile(float(tau_s), np.diff(t), r)[0]


def estimate_correlation_time(times: np.ndarray, residuals: np.ndarray,
                              bounds: tuple[float, float] | None = None,
                              n_grid: int = 48, white: bool = False,
                              design: np.ndarray | None = None) -> CorrelationEstimate:
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
    white : bool
        Model the residuals as the exponential error plus white noise (eq. C4); τ̂ is then
        that of the exponential part, ``white_sigma`` the white noise's σ̂.
    design : (N, p) array_like, optional
        The fit's Jacobian at its solution (the derivatives of the model at the residuals'
        times): the restricted likelihood (eq. C5) of the residuals, which the p fitted
        parameters have reduced; None: the residuals taken for the errors.

    Returns
    -------
    CorrelationEstimate
    """
    t, r, design = _prepare(times, residuals, design)
    dt = np.diff(t)
    lo, hi = bounds if bounds is not None else (float(dt.min()) / 4.0,
                                                 20.0 * float(t[-1] - t[0]))
    if not 0 < lo < hi:
        raise ValueError(f"bounds must satisfy 0 < lo < hi, got ({lo}, {hi})")
    if white:
        g, rho, ll, s2, se_g = _white_fit(dt, r, lo, hi, n_grid, design)
        at_bound = g - math.log(lo) < 1e-3 or math.log(hi) - g < 1e-3
        tau = math.exp(g)
        return CorrelationEstimate(tau, tau * se_g, math.sqrt(rho * s2), ll, bool(at_bound),
                                   math.sqrt((1.0 - rho) * s2))
    grid = np.linspace(math.log(lo), math.log(hi), n_grid)
    ll = np.array([_loglik(math.exp(g), 1.0, dt, r, design)[0] for g in grid])
    k = int(np.argmax(ll))
    a, b = grid[max(k - 1, 0)], grid[min(k + 1, n_grid - 1)]
    res = minimize_scalar(lambda g: -_loglik(math.exp(g), 1.0, dt, r, design)[0], bounds=(a, b),
                          method="bounded", options={"xatol": 1e-6})
    g = float(res.x) if -res.fun >= ll[k] else float(grid[k])
    g = min(max(g, grid[0]), grid[-1])
    best, s2 = _loglik(math.exp(g), 1.0, dt, r, design)
    at_bound = g - grid[0] < 1e-3 or grid[-1] - g < 1e-3
    h = 0.02
    d2 = (_loglik(math.exp(g + h), 1.0, dt, r, design)[0] - 2.0 * best
          + _loglik(math.exp(g - h), 1.0, dt, r, design)[0]) / (h * h)
    tau = math.exp(g)
    se = tau / math.sqrt(-d2) if d2 < 0 else math.inf
    return CorrelationEstimate(tau, se, math.sqrt(s2), best, bool(at_bound))


def _profile_white(tau: float, rho: float, dt: np.ndarray, r: np.ndarray
                   ) -> tuple[float, float]:
    """(ℓ_p, ŝ²) of an exponential error plus white noise (eq. C4) by the Kalman filter's
    innovations: the exponential share ``rho`` of the total variance s² (profiled out)."""
    phi = np.exp(-dt / tau)
    q = rho * -np.expm1(-2.0 * dt / tau)  # process noise of the unit-variance AR(1) part
    w = 1.0 - rho
    n = r.size
    x, pp = 0.0, rho
    nu2 = np.empty(n)
    ss = np.empty(n)
    for b in range(n):
        if b:
            x, pp = phi[b - 1] * x, phi[b - 1] ** 2 * pp + q[b - 1]
        sb = pp + w
        nu = r[b] - x
        k = pp / sb
        x, pp = x + k * nu, (1.0 - k) * pp
        nu2[b], ss[b] = nu * nu, sb
    s2 = float(np.mean(nu2 / ss))
    if not s2 > 0:
        return -math.inf, 0.0
    return (-0.5 * n * (math.log(2.0 * math.pi * s2) + 1.0) - 0.5 * float(np.sum(np.log(ss))),
            s2)


def _innovations(tau: float, rho: float, dt: np.ndarray, cols: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Normalised Kalman innovations ν_b/√S_b of the columns ``cols`` (N, m) under the unit
    correlation ρ exp(−|Δ|/τ) + (1 − ρ) δ (the gains do not depend on the data, so one
    recursion whitens every column: K^{-1/2} cols), and log S_b (N,)."""
    phi = np.exp(-dt / tau)
    q = rho * -np.expm1(-2.0 * dt / tau)
    w = 1.0 - rho
    n = cols.shape[0]
    x = np.zeros(cols.shape[1])
    pp = rho
    out = np.empty_like(cols)
    logs = np.empty(n)
    for b in range(n):
        if b:
            x, pp = phi[b - 1] * x, phi[b - 1] ** 2 * pp + q[b - 1]
        sb = pp + w
        nu = cols[b] - x
        k = pp / sb
        x, pp = x + k * nu, (1.0 - k) * pp
        out[b] = nu / math.sqrt(sb)
        logs[b] = math.log(sb)
    return out, logs


def _loglik(tau: float, rho: float, dt: np.ndarray, r: np.ndarray,
            design: np.ndarray | None) -> tuple[float, float]:
    """(ℓ, ŝ²): eq. (C3) (ρ = 1), (C4), or with the fit's Jacobian the restricted
    likelihood (C5)."""
    if design is None:
        return _profile(tau, dt, r) if rho >= 1.0 else _profile_white(tau, rho, dt, r)
    wc, logs = _innovations(tau, rho, dt, np.column_stack([r, design]))
    wr, wg = wc[:, 0], wc[:, 1:]
    coef, *_ = np.linalg.lstsq(wg, wr, rcond=None)
    e = wr - wg @ coef
    n, p = wr.size, wg.shape[1]
    s2 = float(e @ e) / (n - p)
    if not s2 > 0:
        return -math.inf, 0.0
    logdet_g = np.linalg.slogdet(wg.T @ wg)[1]
    return (-0.5 * (n - p) * (math.log(2.0 * math.pi * s2) + 1.0)
            - 0.5 * float(np.sum(logs)) - 0.5 * float(logdet_g), s2)


def _white_fit(dt: np.ndarray, r: np.ndarray, lo: float, hi: float, n_grid: int,
               design: np.ndarray | None = None) -> tuple[float, float, float, float, float]:
    """(log τ̂, ρ̂, ℓ_p, ŝ², se(log τ)) of eq. (C4): a grid over log τ and ρ, then Nelder-Mead
    on (log τ, logit ρ), the standard error from the inverse Hessian of ℓ_p there."""
    from scipy.optimize import minimize

    u_max = 9.0  # ρ ≤ 1 − 1.2e-4: the white share's lower bound

    def nll(v: np.ndarray) -> float:
        g = min(max(v[0], math.log(lo)), math.log(hi))
        u = min(max(v[1], -u_max), u_max)
        return -_loglik(math.exp(g), 1.0 / (1.0 + math.exp(-u)), dt, r, design)[0]

    best = (math.inf, 0.0, 0.0)
    for g in np.linspace(math.log(lo), math.log(hi), max(n_grid // 3, 8)):
        for u in (-2.0, 0.0, 2.0, 5.0):
            f = nll(np.array([g, u]))
            if f < best[0]:
                best = (f, g, u)
    res = minimize(nll, np.array(best[1:]), method="Nelder-Mead",
                   options={"xatol": 1e-5, "fatol": 1e-7, "maxiter": 400})
    v = res.x if res.fun <= best[0] else np.array(best[1:])
    v = np.array([min(max(v[0], math.log(lo)), math.log(hi)), min(max(v[1], -u_max), u_max)])
    h = 0.02
    hess = np.empty((2, 2))
    for i in range(2):
        for j in range(2):
            ei, ej = np.eye(2)[i] * h, np.eye(2)[j] * h
            hess[i, j] = (nll(v + ei + ej) - nll(v + ei - ej) - nll(v - ei + ej)
                          + nll(v - ei - ej)) / (4 * h * h)
    if abs(v[1]) >= u_max - 1e-6:  # on the ρ bound: the profile in log τ alone
        var_g = 1.0 / hess[0, 0] if hess[0, 0] > 0 else math.inf
    else:
        try:
            cov = np.linalg.inv(hess)
            var_g = float(cov[0, 0]) if cov[0, 0] > 0 and np.all(np.linalg.eigvalsh(hess) > 0) \
                else math.inf
        except np.linalg.LinAlgError:
            var_g = math.inf
    rho = 1.0 / (1.0 + math.exp(-v[1]))
    ll, s2 = _loglik(math.exp(v[0]), rho, dt, r, design)
    return float(v[0]), rho, ll, s2, math.sqrt(var_g) if math.isfinite(var_g) else math.inf


def window_bounds(times: np.ndarray, fraction: float = 0.25) -> tuple[float, float]:
    """Search interval of τ for a fit whose parameters describe the whole window: from a
    quarter of the shortest step to ``fraction`` of the span. A correlation time comparable
    with the window is not told apart from the model's own slow terms by one window's
    residuals (they are confounded with a misfit of the motion model, an offset or a drift of
    the angles), and a τ̂ there treats the slow curvature that carries a TMA's range as noise."""
    t = np.sort(np.asarray(times, float).reshape(-1))
    lo = float(np.diff(t).min()) / 4.0
    return lo, max(float(fraction * (t[-1] - t[0])), 2.0 * lo)


def correlated_whitener(times: np.ndarray, est: CorrelationEstimate
                        ) -> Callable[[np.ndarray], np.ndarray]:
    """``C^{-1/2}`` of the fitted error model (eq. C4 with ``est``'s τ̂, σ̂ and σ̂_w; C1 when
    ``white_sigma`` is 0) at ``times`` (strictly increasing, s), applied to the rows of an
    (N,) or (N, m) array: the normalised Kalman innovations, the same for every column
    (residuals and Jacobian alike), so that a least-squares fit of whitened residuals is the
    generalised least-squares fit, and ``JᵀJ`` of the whitened Jacobian its Fisher
    information under the correlated errors."""
    t = np.asarray(times, float).reshape(-1)
    if t.size > 1 and np.any(np.diff(t) <= 0):
        raise ValueError("the whitener's times must be strictly increasing")
    s2 = est.sigma ** 2 + est.white_sigma ** 2
    rho = est.sigma ** 2 / s2 if s2 > 0 else 1.0
    rho = min(rho, 1.0 - 1e-9)
    dt, scale = np.diff(t), 1.0 / math.sqrt(s2)

    def apply(cols: np.ndarray) -> np.ndarray:
        c = np.asarray(cols, float)
        out, _ = _innovations(est.tau_s, rho, dt, c.reshape(t.size, -1))
        return (out * scale).reshape(c.shape)
    return apply


def solve_compact_estimated(times: np.ndarray, bearings_rad: np.ndarray,
                            array_xy: np.ndarray, sigma_rad: float | None, *,
                            correlation_s: float = 0.0, iterations: int = 2,
                            white: bool = True, restricted: bool = True,
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
    white : bool
        τ̂ of the exponential part of an exponential-plus-white error (eq. C4): the peak
        picker's own scatter is white; the refit's C is exponential (its σ̂ absorbs the white
        part).
    restricted : bool
        τ̂ from the restricted likelihood (eq. C5) with the fit's Jacobian in (x0, y0, γ).
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
        design = None
        if restricted:
            q = np.array([sol.state[0], sol.state[1],
                          math.atan2(sol.state[2], sol.state[3])])
            design = compact_jacobian(q, float(np.hypot(*sol.state[2:4])), t[ok] - sol.t0,
                                      sol.observer)[:, :3]
        est = estimate_correlation_time(t[ok], resid, white=white, design=design)
        sol = solve_compact(t, y, array_xy, sigma_rad, correlation_s=est.tau_s, **kw)
    sol.tau_s = est.tau_s
    sol.tau_sigma_s = est.tau_sigma_s
    return sol
