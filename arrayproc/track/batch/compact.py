"""Stationary compact-array TMA with a speed prior and correlated bearing errors.

Compact-array paper (Urazghildiiev & Hannay), eqs. (1)-(5): a vessel moves straight from
``r(t0) = (x0, y0)`` at speed ``v`` on heading ``γ`` (eq. (1), ``e(γ) = (sin γ, cos γ)``);
the unknowns are ``θ = (x0, y0, γ)`` (eq. (2)); a stationary array measures bearings
``α̂(t) = α(t, θ) + ε(t)`` (eq. (3)) with Gaussian errors of covariance C; the log-likelihood
is ``−½ (α̂ − α(θ))ᵀ C⁻¹ (α̂ − α(θ))`` (eq. (4)) and the estimate, for the assumed (mean)
speed, maximises it by a grid search over x, y and γ (eq. (5)), refined here by a local
least-squares step from the best grid node (``scipy.optimize.least_squares`` on the whitened
residuals).

Bearings from a single static array cannot tell a source at range r and speed v from one at
``k r`` and ``k v`` (every bearing is unchanged): the speed prior is what makes θ observable.
So the estimate is made at ``speed_mps`` (a wrong speed scales the estimated ranges by the
ratio of assumed to true speed and leaves the heading unchanged), and the speed's
uncertainty ``sigma_speed_mps`` enters the bound: the Fisher information on
``(x0, y0, γ, v)`` is ``Gᵀ C⁻¹ G + diag(0, 0, 0, 1/σ_v²)`` (:func:`.fim.compact_fim`).

C is diagonal (``correlation_s = 0``) or exponential, ``C_ij = σ² exp(−|t_i − t_j|/τ)``
(``τ = correlation_s``); its Markov structure gives ``C^{-1/2}`` in O(N)
(:func:`.fim.innovation_coefficients`).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from ._kernels import compact_grid_cost
from .fim import (
    compact_fim,
    compact_jacobian,
    condition_number,
    crlb_from_fim,
    innovation_coefficients,
    range_sigma,
    whiten,
)
from .result import TmaSolution

__all__ = ["compact_bearings", "solve_compact", "state_covariance", "cpa_range_heading"]


def compact_bearings(params: np.ndarray, speed: float, tau: np.ndarray,
                     array_xy: np.ndarray) -> np.ndarray:
    """Bearings ``α(t, θ)`` (rad clockwise from north) of paper eqs. (1), (3).

    Parameters
    ----------
    params : (3,) array_like
        x0, y0 (m), heading γ (rad) at the window start.
    speed : float
        m/s.
    tau : (B,) array_like
        Times since the window start (s).
    array_xy : (2,) array_like
        Array position (m).

    Returns
    -------
    (B,) ndarray
    """
    x0, y0, g = np.asarray(params, float).reshape(3)
    tau = np.asarray(tau, float)
    a = np.asarray(array_xy, float).reshape(2)
    return np.arctan2(x0 + speed * np.sin(g) * tau - a[0], y0 + speed * np.cos(g) * tau - a[1])


def state_covariance(params: np.ndarray, speed: float, cov_params: np.ndarray) -> np.ndarray:
    """Covariance of [x, y, vx, vy] from that of ``(x0, y0, γ[, v])`` (linearised).

    Parameters
    ----------
    params : (3,) array_like
        x0, y0 (m), γ (rad).
    speed : float
        m/s.
    cov_params : (3, 3) or (4, 4) array_like
        Covariance of (x0, y0, γ) (speed known) or (x0, y0, γ, v).

    Returns
    -------
    (4, 4) ndarray
        ``T P Tᵀ`` with ``vx = v sin γ``, ``vy = v cos γ``.
    """
    g = float(np.asarray(params, float)[2])
    p = np.asarray(cov_params, float)
    full = np.zeros((4, 4))
    full[:p.shape[0], :p.shape[1]] = p
    t = np.array([[1.0, 0, 0, 0], [0, 1.0, 0, 0],
                  [0, 0, speed * np.cos(g), np.sin(g)], [0, 0, -speed * np.sin(g), np.cos(g)]])
    return t @ full @ t.T


def cpa_range_heading(params: np.ndarray, speed: float, array_xy: np.ndarray,
                      tau_cpa: float) -> tuple[float, float]:
    """Range from the array (m) at time ``tau_cpa`` (s since the window start) and heading
    (rad) of the track ``params = (x0, y0, γ)`` at ``speed``."""
    x0, y0, g = np.asarray(params, float).reshape(3)
    p = np.array([x0 + speed * np.sin(g) * tau_cpa, y0 + speed * np.cos(g) * tau_cpa])
    return float(np.hypot(*(p - np.asarray(array_xy, float)))), float(g)


def solve_compact(times: np.ndarray, bearings_rad: np.ndarray, array_xy: np.ndarray,
                  sigma_rad: float | None, *, speed_mps: float, sigma_speed_mps: float = 0.0,
                  correlation_s: float = 0.0, t0: float | None = None,
                  t1: float | None = None, max_range_m: float = 5000.0, n_grid: int = 200,
                  n_headings: int = 72) -> TmaSolution:
    """Maximum-likelihood track of a vessel from a static array (paper eqs. (1)-(5)).

    Parameters
    ----------
    times : (B,) array_like
        Bearing times (s), strictly increasing when ``correlation_s > 0``.
    bearings_rad : (B,) array_like
        Measured bearings (rad clockwise from north).
    array_xy : (2,) array_like
        Array position (m).
    sigma_rad : float, optional
        Bearing-error standard deviation (rad); estimated from the whitened residuals when
        None.
    speed_mps : float
        Assumed (mean) speed of the vessel (m/s).
    sigma_speed_mps : float
        Standard deviation of the speed prior (m/s), used in the bound; 0 for a known speed.
    correlation_s : float
        Correlation time of the bearing errors (s); 0 for a diagonal C.
    t0, t1 : float, optional
        Window start (the state's time) and end (s).
    max_range_m : float
        Half-width of the square position grid around the array (m).
    n_grid, n_headings : int
        Grid nodes along x and y, and headings over 360°.

    Returns
    -------
    TmaSolution
        ``method = "compact"``; state [x0, y0, v sin γ, v cos γ]; ``cov``/``crlb`` include the
        speed prior; ``fitted`` the model bearings (rad).
    """
    t = np.asarray(times, float).reshape(-1)
    y = np.asarray(bearings_rad, float).reshape(-1)
    ok = np.isfinite(y)
    t, y = t[ok], y[ok]
    if t.size < 4:
        raise ValueError(f"compact-array TMA needs at least 4 bearings, {t.size} given")
    a = np.asarray(array_xy, float).reshape(2)
    t0 = float(t[0] if t0 is None else t0)
    t1 = float(t[-1] if t1 is None else t1)
    tau = t - t0
    phi, scale = innovation_coefficients(t, sigma_rad or 1.0, correlation_s)
    xs = a[0] + np.linspace(-max_range_m, max_range_m, n_grid)
    ys = a[1] + np.linspace(-max_range_m, max_range_m, n_grid)
    hd = np.arange(n_headings) * (2 * np.pi / n_headings)
    cost = compact_grid_cost(xs, ys, hd, float(speed_mps), tau, a, y, phi, scale)
    i, j, k = np.unravel_index(int(np.argmin(cost)), cost.shape)

    def res(q: np.ndarray) -> np.ndarray:
        e = np.angle(np.exp(1j * (y - compact_bearings(q, speed_mps, tau, a))))
        return whiten(e, phi, scale)

    def jac(q: np.ndarray) -> np.ndarray:
        return -whiten(compact_jacobian(q, speed_mps, tau, a)[:, :3], phi, scale)

    q = least_squares(res, np.array([xs[i], ys[j], hd[k]]), jac=jac, method="lm",
                      x_scale="jac", xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=200).x
    q[2] = q[2] % (2 * np.pi)
    r = res(q)
    c2 = float(np.sum(r**2))
    s2 = c2 / max(t.size - 3, 1)
    sig = sigma_rad if sigma_rad else float(np.sqrt(s2))
    if not sigma_rad:
        c2 = c2 / s2
        s2 = 1.0
    fim = compact_fim(q, speed_mps, tau, a, sig, correlation_s, sigma_speed_mps)
    crlb_p, _ = crlb_from_fim(fim)
    # estimator covariance: the bearing information scaled by the residual variance factor
    if s2 > 0:
        data = fim.copy()
        if fim.shape[0] == 4:
            data[3, 3] -= 1.0 / sigma_speed_mps**2
        data = data / s2
        if fim.shape[0] == 4:
            data[3, 3] += 1.0 / sigma_speed_mps**2
        cov_p, _ = crlb_from_fim(data)
    else:  # a perfect fit
        cov_p = np.zeros_like(fim)
    state = np.array([q[0], q[1], speed_mps * np.sin(q[2]), speed_mps * np.cos(q[2])])
    crlb = state_covariance(q, speed_mps, crlb_p)
    return TmaSolution(
        t0=t0, t1=t1, method="compact", state=state,
        cov=state_covariance(q, speed_mps, cov_p), crlb=crlb, cost=c2,
        fim_cond=float(condition_number(fim)),
        range_sigma=float(range_sigma(state[:2] - a, crlb)), n_used=int(t.size),
        n_rejected=int((~ok).sum()), observer=a, fitted=compact_bearings(q, speed_mps, tau, a))
