"""Numba kernels of the Gaussian filters (L-R paper section IV): EKF, deterministic sample
points (UKF, CKF and Gauss-Hermite differ only by their unit points and weights) and the
shifted Rayleigh filter (Clark, Vinter & Yaqoob 2007).

The kernels are generic in the measurement: a filter evaluates its measurement model between
two kernels (EKF: ``h(x)`` and ``H`` before :func:`ekf_update`; sample points:
:func:`sp_update_points`, then ``h`` on every point, then :func:`sp_update_correct`), so any
model with a function, a Jacobian and a covariance plugs in. Measurement components flagged
``angular`` get wrapped residuals and a circular mean. Every predict/update returns a status:
0 fine, 1 the covariance was not positive definite and was repaired (symmetrised, then a
diagonal jitter added), −1 the state became non-finite and the filter must be declared
diverged.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from arrayproc.track.models._kernels import wrap

_LOG_2PI = math.log(2.0 * math.pi)


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
def ekf_predict(x, P, F, xn, Q) -> int:
    """EKF time update: x ← f(x) = ``xn``, P ← F P Fᵀ + Q (L-R paper eqs. (1)-(6)). In place;
    returns the status."""
    n = x.shape[0]
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
def residual(z, zp, angular, nu) -> None:
    """nu = z − zp, wrapped to [−π, π) on the ``angular`` components."""
    for a in range(z.shape[0]):
        nu[a] = wrap(z[a] - zp[a]) if angular[a] else z[a] - zp[a]


@njit(cache=True)
def ekf_update(x, P, z, zp, H, R, angular):
    """EKF measurement update with any measurement: prediction ``zp`` = h(x), Jacobian ``H``
    (m, n), noise ``R`` (m, m); wrapped residual on angular components, Joseph form
    (I − K H) P (I − K H)ᵀ + K R Kᵀ. Returns (log N(ν; 0, S), status). In place."""
    n = x.shape[0]
    m = z.shape[0]
    nu = np.empty(m)
    residual(z, zp, angular, nu)
    if m == 1:
        h = H[0].copy()
        r = R[0, 0]
        PH = P @ h
        S = h @ PH + r
        K = PH / S
        ll = -0.5 * (_LOG_2PI + math.log(S) + nu[0] * nu[0] / S)
        for i in range(n):
            x[i] += K[i] * nu[0]
        A = np.eye(n) - np.outer(K, h)
        Pn = A @ P @ A.T + r * np.outer(K, K)
    else:
        PHt = P @ H.T
        Sm = H @ PHt + R
        Ls = np.empty((m, m))
        if not _chol(Sm, Ls):
            return -np.inf, -1
        Si = np.linalg.inv(Sm)
        Km = PHt @ Si
        ll = -0.5 * (m * _LOG_2PI + nu @ (Si @ nu))
        for a in range(m):
            ll -= math.log(Ls[a, a])
        dx = Km @ nu
        for i in range(n):
            x[i] += dx[i]
        A = np.eye(n) - Km @ H
        Pn = A @ P @ A.T + Km @ R @ Km.T
    P[:, :] = Pn
    L = np.empty((n, n))
    st = chol_repair(P, L)
    if st >= 0 and (not finite_state(x, P) or not math.isfinite(ll)):
        st = -1
    return ll, st


@njit(cache=True)
def gaussian_innovation(P, zp, z, H, R, angular):
    """Innovation ν = z − h(x) (wrapped on angular components) and its covariance
    S = H P Hᵀ + R of a linearised measurement, for gating."""
    m = z.shape[0]
    nu = np.empty(m)
    residual(z, zp, angular, nu)
    return nu, H @ P @ H.T + R


# ---------------------------------------------------------------------------------------------
# Deterministic sample-point filters (UKF / CKF / GHF)
# ---------------------------------------------------------------------------------------------

@njit(cache=True)
def sp_predict_points(x, P, U, Xs) -> int:
    """Sample points of the time update: X_i = x + L U_i with L Lᵀ = P (P symmetrised, and
    repaired if needed, in place). Writes ``Xs`` (npts, n); returns the status."""
    n = x.shape[0]
    L = np.empty((n, n))
    st = chol_repair(P, L)
    if st < 0:
        return -1
    X = U @ L.T
    for p in range(U.shape[0]):
        for i in range(n):
            Xs[p, i] = x[i] + X[p, i]
    return st


@njit(cache=True)
def sp_predict_moments(x, P, Y, Q, wm, wc, st: int) -> int:
    """Time update from the propagated points ``Y`` (npts, n): mean Σ wm_i Y_i, covariance
    Σ wc_i (Y_i − x̄)(·)ᵀ + Q. ``st`` is the status of :func:`sp_predict_points`. In place
    (``Y`` is overwritten)."""
    n = x.shape[0]
    npts = Y.shape[0]
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
    L = np.empty((n, n))
    st2 = chol_repair(P, L)
    if st2 < 0 or not finite_state(x, P):
        return -1
    return max(st, st2)


@njit(cache=True)
def sp_update_points(x, P, U, Xs, L, nrows: int) -> int:
    """Sample points of the measurement update, redrawn from the predicted (x, P):
    X_i = x + L U_i, each row formed as x_r + Σ_{j ≤ r} L_rj U_ij (L lower triangular), for the
    first ``nrows`` state components (those the measurement reads; the rest of ``Xs`` is left
    as is). Writes ``Xs`` (npts, n) and the factor ``L``; returns the status."""
    st = chol_repair(P, L)
    if st < 0:
        return -1
    for p in range(U.shape[0]):
        for r in range(nrows):
            v = x[r]
            for j in range(r + 1):
                v += L[r, j] * U[p, j]
            Xs[p, r] = v
    return st


@njit(cache=True)
def sp_measurement_moments(Zs, R, angular, U, wm, wc):
    """Predicted measurement, its covariance and the whitened cross term of sample points.

    ``Zs`` (npts, m) = h(X_i). Mean: Σ wm_i Z_i, on angular components unwrapped about the
    first point's value and wrapped back; S = R + Σ wc_i Δz_i Δz_iᵀ with wrapped Δz;
    G = Σ wc_i U_i Δz_iᵀ (n, m), so that the cross-covariance is L G (X_i − x = L U_i).
    Returns (zp, S, G)."""
    npts = Zs.shape[0]
    m = Zs.shape[1]
    n = U.shape[1]
    zp = np.empty(m)
    for a in range(m):
        acc = 0.0
        if angular[a]:
            zref = Zs[0, a]
            for p in range(npts):
                acc += wm[p] * wrap(Zs[p, a] - zref)
            zp[a] = wrap(zref + acc)
        else:
            for p in range(npts):
                acc += wm[p] * Zs[p, a]
            zp[a] = acc
    S = R.copy()
    G = np.zeros((n, m))
    dz = np.empty(m)
    for p in range(npts):
        for a in range(m):
            dz[a] = wrap(Zs[p, a] - zp[a]) if angular[a] else Zs[p, a] - zp[a]
        for a in range(m):
            for b in range(m):
                S[a, b] += wc[p] * dz[a] * dz[b]
        for j in range(n):
            for a in range(m):
                G[j, a] += wc[p] * U[p, j] * dz[a]
    return zp, S, G


@njit(cache=True)
def sp_update_correct(x, P, L, z, Zs, R, angular, U, wm, wc, st: int):
    """Sample-point measurement update from h(X_i) = ``Zs`` (points of
    :func:`sp_update_points`, factor ``L``): Kalman gain L G S⁻¹, wrapped residual.
    Returns (log N(ν; 0, S), status). In place. A scalar measurement takes the moments of
    :func:`sp_measurement_moments` without temporaries (same arithmetic)."""
    n = x.shape[0]
    m = z.shape[0]
    if m == 1:
        ang = angular[0]
        zref = Zs[0, 0]
        acc = 0.0
        if ang:
            for p in range(Zs.shape[0]):
                acc += wm[p] * wrap(Zs[p, 0] - zref)
            zp = wrap(zref + acc)
        else:
            for p in range(Zs.shape[0]):
                acc += wm[p] * Zs[p, 0]
            zp = acc
        s = R[0, 0]
        g = np.zeros(n)
        for p in range(Zs.shape[0]):
            dz = wrap(Zs[p, 0] - zp) if ang else Zs[p, 0] - zp
            s += wc[p] * dz * dz
            for j in range(n):
                g[j] += wc[p] * U[p, j] * dz
        if not s > 0.0:
            return -np.inf, -1
        Pxz = L @ g
        nu = wrap(z[0] - zp) if ang else z[0] - zp
        ll = -0.5 * (_LOG_2PI + math.log(s) + nu * nu / s)
        for i in range(n):
            x[i] += Pxz[i] / s * nu
        for i in range(n):
            for j in range(n):
                P[i, j] -= Pxz[i] * Pxz[j] / s
    else:
        zpv, S, G = sp_measurement_moments(Zs, R, angular, U, wm, wc)
        nuv = np.empty(m)
        residual(z, zpv, angular, nuv)
        Ls = np.empty((m, m))
        if not _chol(S, Ls):
            return -np.inf, -1
        Si = np.linalg.inv(S)
        Pxz2 = L @ G
        K = Pxz2 @ Si
        ll = -0.5 * (m * _LOG_2PI + nuv @ (Si @ nuv))
        for a in range(m):
            ll -= math.log(Ls[a, a])
        dx = K @ nuv
        for i in range(n):
            x[i] += dx[i]
        P[:, :] = P - K @ Pxz2.T
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
