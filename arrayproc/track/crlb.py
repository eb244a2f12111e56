"""Cramér-Rao lower bound for bearings-only target motion analysis with zero process noise.

The target moves at constant velocity with no process noise, so its state at every measurement
time is a deterministic linear function of the initial state,
``x_k = Φ(t_k − t_0) x_0`` with ``Φ(τ) = [[I, τ I], [0, I]]`` (SPL paper eq. (5)). The Fisher
information of ``x_0`` from bearings ``θ_j = h_θ(x_j) + w_j``, ``w_j ~ N(0, σ_θ²)``, is
(thesis eq. (3.53) / (C.8), one scalar measurement per time)

    J_0(k) = J_prior + Σ_{j ≤ k} Φ_jᵀ ∇h_jᵀ ∇h_j Φ_j / σ_θ²,

and the bound on the state at time k is ``CRLB_k = Φ_k J_0(k)⁻¹ Φ_kᵀ``. This is the same bound
as the recursion of Ristic, Arulampalam & Gordon (2003), *Beyond the Kalman Filter*, ch. 4.3.3
and 6.3 (``J_{k+1} = F⁻ᵀ J_k F⁻¹ + H_{k+1}ᵀ R⁻¹ H_{k+1}`` for zero process noise), written in
closed form. With the bearing ``h_θ = atan2(dx, dy)`` (true bearing from north, SPL paper
eq. (9)), ``dx = x − x_o``, ``dy = y − y_o``, ``r² = dx² + dy²``, the gradient is

    ∇h = [dy / r², −dx / r², 0, 0]

(the thesis' eq. (C.11) prints a range ``r`` instead of ``r²`` in the denominators and a stray
``c``; this is the correct derivative, checked numerically in the tests).

The thesis' eq. (3.54) (condition number of J) tells whether the problem is observable; where
J_0(k) is singular (too few bearings and no prior) the bound is reported as NaN.
"""

from __future__ import annotations

import numpy as np

__all__ = ["bearings_only_crlb", "cv_transition", "bearing_gradient", "position_rmse_bound",
           "polar_prior_covariance"]


def cv_transition(tau: float | np.ndarray) -> np.ndarray:
    """Constant-velocity transition matrix Φ(τ) for state [x, y, vx, vy] (SPL paper eq. (5)).

    ``tau`` may be an array; the result then has shape ``tau.shape + (4, 4)``.
    """
    tau = np.asarray(tau, dtype=float)
    phi = np.zeros(tau.shape + (4, 4))
    phi[..., 0, 0] = phi[..., 1, 1] = phi[..., 2, 2] = phi[..., 3, 3] = 1.0
    phi[..., 0, 2] = tau
    phi[..., 1, 3] = tau
    return phi


def bearing_gradient(target_pos: np.ndarray, observer_pos: np.ndarray) -> np.ndarray:
    """Gradient of the true bearing atan2(dx, dy) w.r.t. the target state, shape (n, 4).

    SPL paper eq. (9) differentiated: ``[dy/r², −dx/r², 0, 0]``.
    """
    d = np.asarray(target_pos, dtype=float) - np.asarray(observer_pos, dtype=float)
    d = np.atleast_2d(d)
    r2 = d[:, 0] ** 2 + d[:, 1] ** 2
    g = np.zeros((d.shape[0], 4))
    g[:, 0] = d[:, 1] / r2
    g[:, 1] = -d[:, 0] / r2
    return g


def bearings_only_crlb(x0: np.ndarray, times: np.ndarray, observer_pos: np.ndarray,
                       sigma_bearing_rad: float,
                       prior_info: np.ndarray | None = None) -> np.ndarray:
    """CRLB on the target state [x, y, vx, vy] at each bearing time, zero process noise.

    Parameters
    ----------
    x0 : (4,) array_like
        True target state [x, y, vx, vy] (m, m/s) at ``times[0]``.
    times : (n,) array_like
        Measurement times (s), non-decreasing.
    observer_pos : (n, 2) array_like
        Observer position (x east, y north) in m at each time.
    sigma_bearing_rad : float
        Standard deviation of the bearing noise (rad).
    prior_info : (4, 4) array_like, optional
        Prior Fisher information on the state at ``times[0]`` (the inverse of the prior
        covariance, Ristic et al. 2003 ch. 6.3 ``J_1 = P_1⁻¹``). Default: no prior.

    Returns
    -------
    (n, 4, 4) ndarray
        ``CRLB_k = Φ_k J_0(k)⁻¹ Φ_kᵀ`` where ``J_0(k)`` is the information on the initial state
        from the prior and the bearings at times ``≤ t_k`` (thesis eq. (3.53); Ristic,
        Arulampalam & Gordon 2003, ch. 4.3.3). NaN where ``J_0(k)`` is singular.
    """
    x0 = np.asarray(x0, dtype=float).reshape(4)
    t = np.asarray(times, dtype=float).reshape(-1)
    obs = np.asarray(observer_pos, dtype=float).reshape(t.size, 2)
    if sigma_bearing_rad <= 0:
        raise ValueError("sigma_bearing_rad must be > 0")
    phi = cv_transition(t - t[0])                       # (n, 4, 4)
    xk = phi @ x0                                       # (n, 4)
    g = bearing_gradient(xk[:, :2], obs)                # (n, 4): ∂h_k/∂x_k
    gx0 = np.einsum("ni,nij->nj", g, phi)               # ∂h_k/∂x_0 = ∇h_k Φ_k
    info_terms = gx0[:, :, None] * gx0[:, None, :] / sigma_bearing_rad**2
    j0 = np.cumsum(info_terms, axis=0)
    if prior_info is not None:
        j0 = j0 + np.asarray(prior_info, dtype=float).reshape(4, 4)
    out = np.full((t.size, 4, 4), np.nan)
    for k in range(t.size):
        jk = 0.5 * (j0[k] + j0[k].T)
        # Judge singularity on the scale-free (correlation-normalised) matrix: position and
        # velocity information differ by many orders of magnitude.
        d = np.sqrt(np.abs(np.diag(jk)))
        if np.any(d == 0):
            continue
        jn = jk / np.outer(d, d)
        if np.linalg.cond(jn) > 1e12:
            continue
        inv = np.linalg.inv(jn) / np.outer(d, d)
        out[k] = phi[k] @ inv @ phi[k].T
    return out


def position_rmse_bound(crlb: np.ndarray) -> np.ndarray:
    """Lower bound on the position RMSE, ``sqrt(P_xx + P_yy)`` (m), from (n, 4, 4) bounds."""
    crlb = np.asarray(crlb)
    return np.sqrt(crlb[..., 0, 0] + crlb[..., 1, 1])


def polar_prior_covariance(bearing_rad: float, range_m: float, sigma_bearing_rad: float,
                           sigma_range_m: float, speed: float, course_rad: float,
                           sigma_speed: float, sigma_course_rad: float) -> np.ndarray:
    """Covariance of [x, y, vx, vy] (relative position, velocity) of a polar prior, linearised.

    Position ``(r sin β, r cos β)`` with independent ``r``, ``β``; velocity
    ``(s sin c, s cos c)`` with independent ``s``, ``c`` (Ristic et al. 2003 ch. 6.3: the
    initial information ``J_1 = P_1⁻¹`` of the CRLB is the inverse of this covariance).
    """
    sb, cb = np.sin(bearing_rad), np.cos(bearing_rad)
    jp = np.array([[sb, range_m * cb], [cb, -range_m * sb]])
    sc, cc = np.sin(course_rad), np.cos(course_rad)
    jv = np.array([[sc, speed * cc], [cc, -speed * sc]])
    p = np.zeros((4, 4))
    p[:2, :2] = jp @ np.diag([sigma_range_m**2, sigma_bearing_rad**2]) @ jp.T
    p[2:, 2:] = jv @ np.diag([sigma_speed**2, sigma_course_rad**2]) @ jv.T
    return p
