"""Numba kernels for the Gaussian bearings-only trackers (issue 6).

Everything here works in SI units and radians on the *relative* state of the L-R paper,
``X = X_target − X_observer = [x, y, ẋ, ẏ]`` (constant velocity, CV) or ``[x, y, ẋ, ẏ, ψ]``
(constant turn, CT, ψ the target's turn rate in rad/s, positive anticlockwise as in the
paper's eq. (5)). The observer's absolute state ``[x_o, y_o, ẋ_o, ẏ_o]`` enters through the
input vector of eqs. (3) and (5b), written here as ``X_k = F(X_{k−1} + X^o_{k−1}) − X^o_k``,
which is algebraically the paper's ``F X_{k−1} − ℧_{k−1,k}``.

Filters: ``KIND_EKF`` (extended Kalman), ``KIND_SP`` (deterministic sample points: UKF, CKF
and Gauss-Hermite differ only by their unit points and weights) and ``KIND_SRF`` (shifted
Rayleigh, Clark, Vinter & Yaqoob 2007). Each predict/update returns a status code: 0 fine,
1 the covariance was not positive definite and was repaired (symmetrised, then a diagonal
jitter added), −1 the state became non-finite and the filter must be declared diverged.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

MODEL_CV = 0
MODEL_CT = 1
KIND_EKF = 0
KIND_SP = 1
KIND_SRF = 2  # shifted Rayleigh, likelihood of the L-R paper section IV
KIND_SRF_EXACT = 3  # shifted Rayleigh, exact (projected normal) bearing likelihood

_LOG_2PI = math.log(2.0 * math.pi)


@njit(cache=True)
def wrap(a: float) -> float:
    """Wrap an angle (rad) to [−π, π)."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi


@njit(cache=True)
def ct_coeffs(psi: float, T: float):
    """sin(ψT)/ψ, (1−cos(ψT))/ψ, cos(ψT), sin(ψT) of L-R paper eq. (5), series near ψ = 0."""
    wt = psi * T
    s = math.sin(wt)
    c = math.cos(wt)
    if abs(wt) > 1e-6:
        a = s / psi
        b = (1.0 - c) / psi
    else:
        a = T * (1.0 - wt * wt / 6.0)
        b = T * wt * (0.5 - wt * wt / 24.0)
    return a, b, c, s


@njit(cache=True)
def propagate(model: int, x, T: float, o0, o1, out) -> None:
    """Relative-state transition, L-R paper eqs. (1)-(3) (CV) and (1), (5) (CT).

    ``o0``, ``o1``: observer [x, y, ẋ, ẏ] at the previous and current time. Writes ``out``.
    """
    ax = x[0] + o0[0]
    ay = x[1] + o0[1]
    avx = x[2] + o0[2]
    avy = x[3] + o0[3]
    if model == MODEL_CV:
        out[0] = ax + T * avx - o1[0]
        out[1] = ay + T * avy - o1[1]
        out[2] = avx - o1[2]
        out[3] = avy - o1[3]
    else:
        a, b, c, s = ct_coeffs(x[4], T)
        out[0] = ax + a * avx - b * avy - o1[0]
        out[1] = ay + b * avx + a * avy - o1[1]
        out[2] = c * avx - s * avy - o1[2]
        out[3] = s * avx + c * avy - o1[3]
        out[4] = x[4]


@njit(cache=True)
def transition_jacobian(model: int, x, T: float, o0, F) -> None:
    """Jacobian of :func:`propagate` w.r.t. the relative state (eq. (2) for CV, eq. (5) plus
    the derivative with respect to ψ for CT). Writes ``F`` (n, n)."""
    n = F.shape[0]
    for i in range(n):
        for j in range(n):
            F[i, j] = 1.0 if i == j else 0.0
    if model == MODEL_CV:
        F[0, 2] = T
        F[1, 3] = T
        return
    psi = x[4]
    avx = x[2] + o0[2]
    avy = x[3] + o0[3]
    a, b, c, s = ct_coeffs(psi, T)
    F[0, 2] = a
    F[0, 3] = -b
    F[1, 2] = b
    F[1, 3] = a
    F[2, 2] = c
    F[2, 3] = -s
    F[3, 2] = s
    F[3, 3] = c
    wt = psi * T
    if abs(wt) > 1e-4:
        da = (T * c * psi - s) / (psi * psi)  # d/dψ sin(ψT)/ψ
        db = (T * s * psi - (1.0 - c)) / (psi * psi)  # d/dψ (1−cos(ψT))/ψ
    else:
        da = -T * T * wt / 3.0
        db = T * T * (0.5 - wt * wt / 8.0)
    F[0, 4] = da * avx - db * avy
    F[1, 4] = db * avx + da * avy
    F[2, 4] = -T * s * avx - T * c * avy
    F[3, 4] = T * c * avx - T * s * avy


@njit(cache=True)
def process_noise(model: int, T: float, q1: float, q2: float, Q) -> None:
    """Process noise covariance, L-R paper eq. (4) (CV) and eq. (6) (CT). Writes ``Q``."""
    n = Q.shape[0]
    for i in range(n):
        for j in range(n):
            Q[i, j] = 0.0
    t3 = T * T * T / 3.0 * q1
    t2 = T * T / 2.0 * q1
    Q[0, 0] = t3
    Q[1, 1] = t3
    Q[0, 2] = t2
    Q[2, 0] = t2
    Q[1, 3] = t2
    Q[3, 1] = t2
    Q[2, 2] = T * q1
    Q[3, 3] = T * q1
    if model == MODEL_CT:
        Q[4, 4] = q2 * T


@njit(cache=True)
def bearing(x) -> float:
    """Bearing measurement function γ(X) = atan2(x, y), L-R paper eq. (7)."""
    return math.atan2(x[0], x[1])


# ---------------------------------------------------------------------------------------------
# Covariance hygiene
# ---------------------------------------------------------------------------------------------

@njit(cache=True)
def _chol(A, L) -> bool:
    """Lower Cholesky factor of a small SPD matrix; False if a pivot is not positive."""
    n = A.shape[0]
    for j in range(n):
        s = A[j, j]
        for k in range(j):
            s -= L[j, k] * L[j, k]
        if not s > 0.0:
            return False
        d = math.sqrt(s)
        L[j, j] = d
        for i in range(j + 1, n):
            t = A[i, j]
            for k in range(j):
                t -= L[i, k] * L[j, k]
            L[i, j] = t / d
        for i in range(j):
            L[i, j] = 0.0
    return True


@njit(cache=True)
def symmetrise(P) -> None:
    n = P.shape[0]
    for i in range(n):
        for j in range(i + 1, n):
            m = 0.5 * (P[i, j] + P[j, i])
            P[i, j] = m
            P[j, i] = m


@njit(cache=True)
def chol_repair(P, L) -> int:
    """Symmetrise ``P`` and factor it; on a non-positive pivot add a growing diagonal jitter
    (1e-10 … 1e-2 of the largest variance) to ``P`` until it factors.

    Returns 0 (factored as is), 1 (``P`` repaired in place) or −1 (non-finite, not repaired).
    """
    n = P.shape[0]
    symmetrise(P)
    scale = 0.0
    for i in range(n):
        if not math.isfinite(P[i, i]):
            return -1
        scale = max(scale, abs(P[i, i]))
    if _chol(P, L):
        return 0
    if scale == 0.0:
        scale = 1.0
    eps = 1e-10
    while eps <= 1e-2:
        for i in range(n):
            P[i, i] += eps * scale
        if _chol(P, L):
            return 1
        eps *= 10.0
    return -1


@njit(cache=True)
def finite_state(x, P) -> bool:
    n = x.shape[0]
    for i in range(n):
        if not math.isfinite(x[i]):
            return False
        for j in range(n):
            if not math.isfinite(P[i, j]):
                return False
    return True


# ---------------------------------------------------------------------------------------------
# EKF
# ---------------------------------------------------------------------------------------------

@njit(cache=True)
def ekf_predict(model: int, x, P, T: float, o0, o1, Q) -> int:
    """EKF time update: x ← f(x), P ← F P Fᵀ + Q (eqs. (1)-(6)). In place; returns status."""
    n = x.shape[0]
    F = np.empty((n, n))
    transition_jacobian(model, x, T, o0, F)
    xn = np.empty(n)
    propagate(model, x, T, o0, o1, xn)
    FP = F @ P
    Pn = FP @ F.T + Q
    x[:] = xn
    P[:, :] = Pn
    L = np.empty((n, n))
    st = chol_repair(P, L)
    if st >= 0 and not finite_state(x, P):
        st = -1
    return st


@njit(cache=True)
def ekf_update(x, P, z: float, R: float):
    """EKF measurement update with the bearing of eq. (7), wrapped residual and Joseph form.

    Returns (log-likelihood of eq. (9), status). In place.
    """
    n = x.shape[0]
    r2 = x[0] * x[0] + x[1] * x[1]
    H = np.zeros(n)
    H[0] = x[1] / r2
    H[1] = -x[0] / r2
    zp = bearing(x)
    PH = P @ H
    S = H @ PH + R
    K = PH / S
    nu = wrap(z - zp)
    ll = -0.5 * (_LOG_2PI + math.log(S) + nu * nu / S)
    for i in range(n):
        x[i] += K[i] * nu
    # Joseph form (I − K H) P (I − K H)ᵀ + K R Kᵀ
    A = np.eye(n) - np.outer(K, H)
    Pn = A @ P @ A.T + R * np.outer(K, K)
    P[:, :] = Pn
    L = np.empty((n, n))
    st = chol_repair(P, L)
    if st >= 0 and (not finite_state(x, P) or not math.isfinite(ll)):
        st = -1
    return ll, st


# ---------------------------------------------------------------------------------------------
# Deterministic sample-point filters (UKF / CKF / GHF)
# ---------------------------------------------------------------------------------------------

@njit(cache=True)
def sp_predict(model: int, x, P, T: float, o0, o1, Q, U, wm, wc) -> int:
    """Sample-point time update: X_i = x + L U_i (L Lᵀ = P), propagate each point through
    eqs. (1)-(6), mean Σ wm_i f(X_i), covariance Σ wc_i (f(X_i) − x̄)(·)ᵀ + Q. In place."""
    n = x.shape[0]
    npts = U.shape[0]
    L = np.empty((n, n))
    st = chol_repair(P, L)
    if st < 0:
        return -1
    X = U @ L.T
    Y = np.empty((npts, n))
    Xi = np.empty(n)
    yi = np.empty(n)
    for p in range(npts):
        for i in range(n):
            Xi[i] = x[i] + X[p, i]
        propagate(model, Xi, T, o0, o1, yi)
        for i in range(n):
            Y[p, i] = yi[i]
    xm = wm @ Y
    for p in range(npts):
        for i in range(n):
            Y[p, i] -= xm[i]
    D = Y.T.copy()
    for p in range(npts):
        w = wc[p]
        for i in range(n):
            D[i, p] *= w
    Pn = D @ Y + Q
    x[:] = xm
    P[:, :] = Pn
    st2 = chol_repair(P, L)
    if st2 < 0 or not finite_state(x, P):
        return -1
    return max(st, st2)


@njit(cache=True)
def sp_update(x, P, z: float, R: float, U, wm, wc):
    """Sample-point measurement update with the bearing of eq. (7).

    Points are redrawn from the predicted (x, P): X_i = x + L U_i. The predicted bearing is the
    weighted mean of the point bearings unwrapped around the first point's bearing; residuals
    are wrapped. Because X_i − x = L U_i, the cross-covariance is L Σ wc_i U_i Δz_i, and only
    the first two (position) rows of L U_i are needed for the bearings.
    Returns (log-likelihood of eq. (9), status). In place.
    """
    n = x.shape[0]
    npts = U.shape[0]
    L = np.empty((n, n))
    st = chol_repair(P, L)
    if st < 0:
        return -np.inf, -1
    Zs = np.empty(npts)
    l00 = L[0, 0]
    l10 = L[1, 0]
    l11 = L[1, 1]
    for p in range(npts):
        Zs[p] = math.atan2(x[0] + l00 * U[p, 0], x[1] + l10 * U[p, 0] + l11 * U[p, 1])
    zref = Zs[0]
    zp = 0.0
    for p in range(npts):
        zp += wm[p] * wrap(Zs[p] - zref)
    zp = wrap(zref + zp)
    S = R
    g = np.zeros(n)  # Σ wc_i U_i Δz_i
    for p in range(npts):
        dz = wrap(Zs[p] - zp)
        S += wc[p] * dz * dz
        for j in range(n):
            g[j] += wc[p] * U[p, j] * dz
    if not S > 0.0:
        return -np.inf, -1
    Pxz = L @ g
    nu = wrap(z - zp)
    ll = -0.5 * (_LOG_2PI + math.log(S) + nu * nu / S)
    for i in range(n):
        x[i] += Pxz[i] / S * nu
    for i in range(n):
        for j in range(n):
            P[i, j] -= Pxz[i] * Pxz[j] / S
    st2 = chol_repair(P, L)
    if st2 < 0 or not finite_state(x, P) or not math.isfinite(ll):
        return ll, -1
    return ll, max(st, st2)


# ---------------------------------------------------------------------------------------------
# Shifted Rayleigh filter
# ---------------------------------------------------------------------------------------------

@njit(cache=True)
def shifted_rayleigh_moments(u: float):
    """Mean ρ(u) and second moment of the shifted Rayleigh density p(t) ∝ t exp(−(t−u)²/2),
    t ≥ 0 (Clark, Vinter & Yaqoob 2007): ρ = ((1+u²)Φ + uφ)/(φ + uΦ), E[t²] = 2 + uρ.

    For u < −3 both closed forms cancel catastrophically; there, with a = −u and the Mills
    ratio's continued fraction Φ(u)/φ(u) = 1/(a + 1/(a + 2/(a + 3/(a + …)))), they reduce to
    ρ = 2/(a + f) and E[t²] = 2f/(a + f) with f = 3/(a + 4/(a + 5/(a + …))), evaluated
    backwards without cancellation."""
    if u >= -3.0:
        phi = math.exp(-0.5 * u * u) / math.sqrt(2.0 * math.pi)
        Phi = 0.5 * math.erfc(-u / math.sqrt(2.0))
        rho = ((1.0 + u * u) * Phi + u * phi) / (phi + u * Phi)
        return rho, 2.0 + u * rho
    a = -u
    f = 0.0
    for k in range(200, 2, -1):
        f = k / (a + f)
    return 2.0 / (a + f), 2.0 * f / (a + f)


@njit(cache=True)
def _log_phi_plus_u_Phi(u: float) -> float:
    """log(φ(u) + u Φ(u)); for u < −3 as log φ(u) + log(c/(a + c)), a = −u,
    c = 1/(a + 2/(a + 3/(a + …))) (Mills-ratio continued fraction, no cancellation)."""
    if u >= -3.0:
        return math.log(math.exp(-0.5 * u * u) / math.sqrt(2.0 * math.pi)
                        + u * 0.5 * math.erfc(-u / math.sqrt(2.0)))
    a = -u
    f = 0.0
    for k in range(200, 1, -1):
        f = k / (a + f)
    c = 1.0 / (a + f)
    return -0.5 * u * u - 0.5 * _LOG_2PI + math.log(c / (a + c))


@njit(cache=True)
def srf_update(x, P, z: float, sigma: float, exact: bool = False):
    """Shifted Rayleigh measurement update (Clark, Vinter & Yaqoob 2007), L-R paper section IV.

    Measurement model b = π(H X + w), b = [sin z, cos z]ᵀ, w ~ N(0, R^m I₂) with
    R^m = σθ² (x̂² + ŷ² + P₁₁ + P₂₂); V = H P Hᵀ + R^m I₂, α = bᵀV⁻¹b, u = bᵀV⁻¹H x̂ / √α,
    γ = ρ(u)/√α (the conditional mean of |HX + w| given b). Posterior moments:
    x̂ + K(γ b − H x̂), P − K H P + Var(s) K b bᵀ Kᵀ with K = P Hᵀ V⁻¹, Var(s) = (2 + uρ − ρ²)/α.

    Returns (log-likelihood, status). The likelihood is the L-R paper's section-IV
    N(γ b; H x̂, V), or with ``exact`` the density of the bearing itself under the same model
    (the projected normal, ∫ s N(s b; H x̂, V) ds):
    log p(θ) = −½ log(2π) − ½ log|V| − ½(x̂ᵀHᵀV⁻¹H x̂ − u²) − log α + log(φ(u) + uΦ(u)).
    """
    n = x.shape[0]
    b0 = math.sin(z)
    b1 = math.cos(z)
    Rm = sigma * sigma * (x[0] * x[0] + x[1] * x[1] + P[0, 0] + P[1, 1])
    v00 = P[0, 0] + Rm
    v01 = 0.5 * (P[0, 1] + P[1, 0])
    v11 = P[1, 1] + Rm
    det = v00 * v11 - v01 * v01
    if not det > 0.0:
        return -np.inf, -1
    i00 = v11 / det
    i01 = -v01 / det
    i11 = v00 / det
    vb0 = i00 * b0 + i01 * b1  # V⁻¹ b
    vb1 = i01 * b0 + i11 * b1
    alpha = b0 * vb0 + b1 * vb1
    beta = vb0 * x[0] + vb1 * x[1]
    sa = math.sqrt(alpha)
    u = beta / sa
    rho, m2 = shifted_rayleigh_moments(u)
    gamma = rho / sa
    var_s = (m2 - rho * rho) / alpha
    e0 = gamma * b0 - x[0]
    e1 = gamma * b1 - x[1]
    if exact:
        mvm = x[0] * (i00 * x[0] + i01 * x[1]) + x[1] * (i01 * x[0] + i11 * x[1])
        ll = -0.5 * _LOG_2PI - 0.5 * math.log(det) - 0.5 * (mvm - u * u) - math.log(alpha) \
            + _log_phi_plus_u_Phi(u)
    else:
        ll = -_LOG_2PI - 0.5 * math.log(det) - 0.5 * (
            e0 * (i00 * e0 + i01 * e1) + e1 * (i01 * e0 + i11 * e1))
    # K = P Hᵀ V⁻¹ (n × 2)
    K = np.empty((n, 2))
    for i in range(n):
        K[i, 0] = P[i, 0] * i00 + P[i, 1] * i01
        K[i, 1] = P[i, 0] * i01 + P[i, 1] * i11
    Kb = np.empty(n)
    for i in range(n):
        Kb[i] = K[i, 0] * b0 + K[i, 1] * b1
    HP = P[:2, :].copy()
    for i in range(n):
        x[i] += K[i, 0] * e0 + K[i, 1] * e1
    for i in range(n):
        for j in range(n):
            P[i, j] += -(K[i, 0] * HP[0, j] + K[i, 1] * HP[1, j]) + var_s * Kb[i] * Kb[j]
    L = np.empty((n, n))
    st = chol_repair(P, L)
    if st < 0 or not finite_state(x, P) or not math.isfinite(ll):
        return ll, -1
    return ll, st


# ---------------------------------------------------------------------------------------------
# Generic dispatch, initialisation and the two-hypothesis L-R scheme
# ---------------------------------------------------------------------------------------------

@njit(cache=True)
def filter_predict(kind: int, model: int, x, P, T: float, o0, o1, q1: float, q2: float,
                   Upred, wmpred, wcpred) -> int:
    """One time update of filter ``kind`` (EKF; sample points; SRF: exact linear prediction
    for CV, sample points ``Upred`` for the non-linear CT model, L-R paper section IV)."""
    n = x.shape[0]
    Q = np.empty((n, n))
    process_noise(model, T, q1, q2, Q)
    if kind == KIND_EKF or (kind >= KIND_SRF and model == MODEL_CV):
        return ekf_predict(model, x, P, T, o0, o1, Q)
    return sp_predict(model, x, P, T, o0, o1, Q, Upred, wmpred, wcpred)


@njit(cache=True)
def filter_update(kind: int, x, P, z: float, sigma: float, U, wm, wc):
    """One bearing update of filter ``kind``; returns (log-likelihood, status)."""
    if kind == KIND_EKF:
        return ekf_update(x, P, z, sigma * sigma)
    if kind == KIND_SRF or kind == KIND_SRF_EXACT:
        return srf_update(x, P, z, sigma, kind == KIND_SRF_EXACT)
    return sp_update(x, P, z, sigma * sigma, U, wm, wc)


@njit(cache=True)
def init_from_bearing(z: float, own, r_mean: float, sigma_r: float, s_mean: float,
                      sigma_s: float, sigma_theta: float, sigma_c: float, sigma_psi: float,
                      x, P, r0: float, s0: float, dc: float) -> None:
    """Initialisation from the first bearing (Ristic, Arulampalam & Gordon 2003, ch. 6):
    range r ~ N(r̄, σr²) on the measured bearing, target speed s ~ N(s̄, σs²) on a course
    c ~ N(z + π, σc²) (heading towards the observer); Gaussian moments by linearisation.
    The mean is taken at (r0, s0, z + π + dc) — (r̄, s̄, z + π) for the prior mean, or a draw
    from the prior in Monte Carlo runs. For CT (len(x) == 5) the turn rate starts at 0 with
    standard deviation σψ."""
    n = x.shape[0]
    sz = math.sin(z)
    cz = math.cos(z)
    c = z + math.pi
    sc = math.sin(c)
    cc = math.cos(c)
    x[0] = r0 * sz
    x[1] = r0 * cz
    x[2] = s0 * math.sin(c + dc) - own[2]
    x[3] = s0 * math.cos(c + dc) - own[3]
    for i in range(n):
        for j in range(n):
            P[i, j] = 0.0
    rt2 = (r_mean * sigma_theta) ** 2
    sr2 = sigma_r * sigma_r
    P[0, 0] = rt2 * cz * cz + sr2 * sz * sz
    P[1, 1] = rt2 * sz * sz + sr2 * cz * cz
    P[0, 1] = P[1, 0] = (sr2 - rt2) * sz * cz
    sc2 = (s_mean * sigma_c) ** 2
    ss2 = sigma_s * sigma_s
    P[2, 2] = sc2 * cc * cc + ss2 * sc * sc
    P[3, 3] = sc2 * sc * sc + ss2 * cc * cc
    P[2, 3] = P[3, 2] = (ss2 - sc2) * sc * cc
    if n == 5:
        x[4] = 0.0
        P[4, 4] = sigma_psi * sigma_psi


@njit(cache=True)
def run_track(kind: int, model: int, n_hyp: int, times, zs, own, sigma: float, q1: float,
              q2: float, prior, init_draw, U, wm, wc, Upred, wmpred, wcpred, xs_out, Ps_out,
              w_out):
    """Run one filter (``n_hyp`` = 1) or the two-hypothesis L-R scheme (``n_hyp`` = 2,
    L-R paper eqs. (9)-(13)) over one sequence of bearings.

    times (K,), zs (K, n_hyp) bearings in rad (column h feeds hypothesis h), own (K, 4)
    observer states, prior = [r̄, σr, s̄, σs, σθ, σc, σψ], init_draw = (r0, s0, dc) the
    initial range, speed and course offset of the mean (see :func:`init_from_bearing`).
    Writes the combined estimate xs_out (K, n) (eq. (12)), its covariance Ps_out (K, n, n)
    (eq. (13)) and the weights w_out (K, n_hyp) (eqs. (10)-(11)). Returns a status: bit 1 a
    covariance was repaired,
    bit 2 a hypothesis diverged (its weight is set to zero), bit 4 every hypothesis diverged
    (the estimate is then frozen at its last finite value).
    """
    n = xs_out.shape[1]
    K = times.shape[0]
    X = np.empty((n_hyp, n))
    P = np.empty((n_hyp, n, n))
    logw = np.empty(n_hyp)
    alive = np.ones(n_hyp, dtype=np.bool_)
    status = 0
    for h in range(n_hyp):
        init_from_bearing(zs[0, h], own[0], prior[0], prior[1], prior[2], prior[3], prior[4],
                          prior[5], prior[6], X[h], P[h], init_draw[0], init_draw[1],
                          init_draw[2])
        logw[h] = -math.log(n_hyp)
    for k in range(K):
        if k > 0:
            T = times[k] - times[k - 1]
            for h in range(n_hyp):
                if not alive[h]:
                    continue
                st = filter_predict(kind, model, X[h], P[h], T, own[k - 1], own[k], q1, q2,
                                    Upred, wmpred, wcpred)
                ll = 0.0
                if st >= 0:
                    ll, st2 = filter_update(kind, X[h], P[h], zs[k, h], sigma, U, wm, wc)
                    st = -1 if st2 < 0 else max(st, st2)
                if st < 0:
                    alive[h] = False
                    logw[h] = -np.inf
                    status |= 2
                else:
                    if st > 0:
                        status |= 1
                    logw[h] += ll
            # normalise the weights, eqs. (10)-(11), in the log domain
            mx = -np.inf
            for h in range(n_hyp):
                if alive[h] and logw[h] > mx:
                    mx = logw[h]
            if mx == -np.inf:
                status |= 4
                for kk in range(k, K):
                    xs_out[kk] = xs_out[k - 1]
                    Ps_out[kk] = Ps_out[k - 1]
                    w_out[kk] = w_out[k - 1]
                return status
            tot = 0.0
            for h in range(n_hyp):
                tot += math.exp(logw[h] - mx) if alive[h] else 0.0
            lt = mx + math.log(tot)
            for h in range(n_hyp):
                logw[h] = logw[h] - lt if alive[h] else -np.inf
        # combined estimate eq. (12) and covariance eq. (13)
        for i in range(n):
            xs_out[k, i] = 0.0
        for h in range(n_hyp):
            w = math.exp(logw[h]) if alive[h] else 0.0
            w_out[k, h] = w
            if w > 0.0:
                for i in range(n):
                    xs_out[k, i] += w * X[h, i]
        for i in range(n):
            for j in range(n):
                Ps_out[k, i, j] = 0.0
        for h in range(n_hyp):
            w = w_out[k, h]
            if w > 0.0:
                for i in range(n):
                    di = X[h, i] - xs_out[k, i]
                    for j in range(n):
                        Ps_out[k, i, j] += w * (P[h, i, j] + di * (X[h, j] - xs_out[k, j]))
    return status


@njit(cache=True, nogil=True)
def run_montecarlo(kind: int, model: int, n_hyp: int, times, zs, own, sigma: float, q1: float,
                   q2: float, prior, init_draws, U, wm, wc, Upred, wmpred, wcpred, n: int,
                   est, wts, Pfin, status) -> None:
    """:func:`run_track` over independent runs (rows of ``zs`` (R, K, n_hyp) and
    ``init_draws`` (R, 3)). Writes estimates ``est`` (R, K, 4) (position and velocity of
    eq. (12)), weights ``wts`` (R, K, n_hyp), final covariances ``Pfin`` (R, n, n) and
    ``status`` (R,). Releases the GIL: :mod:`arrayproc.evaluate.montecarlo` runs chunks of runs
    on several threads (a ``parallel=True`` kernel would take minutes to compile)."""
    R = zs.shape[0]
    K = times.shape[0]
    xs = np.empty((K, n))
    Ps = np.empty((K, n, n))
    ws = np.empty((K, n_hyp))
    for r in range(R):
        status[r] = run_track(kind, model, n_hyp, times, zs[r], own, sigma, q1, q2, prior,
                              init_draws[r], U, wm, wc, Upred, wmpred, wcpred, xs, Ps, ws)
        est[r] = xs[:, :4]
        wts[r] = ws
        Pfin[r] = Ps[K - 1]
