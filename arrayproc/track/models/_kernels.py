"""Numba kernels of the motion and measurement models (L-R paper eqs. (1)-(8), SPL paper
eqs. (12), (16), (31)-(33)).

State: the *relative* target state ``X = X_target − X_observer``, ``[x, y, ẋ, ẏ]`` (CV) or
``[x, y, ẋ, ẏ, ψ]`` (CT, ψ in rad/s, positive anticlockwise as in L-R paper eq. (5)); SI units
and radians. The observer's absolute state ``o = [x_o, y_o, ẋ_o, ẏ_o]`` enters the motion as
``X_k = F(X_{k−1} + o_{k−1}) − o_k``, algebraically the paper's ``F X_{k−1} − ℧_{k−1,k}``.

Every ``*_points`` kernel evaluates its model on a set of sample points (rows), the form the
sample-point filters call; the scalar kernels are what the fused Monte Carlo kernels inline.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from arrayproc.geo.angles import wrap_pi_scalar

wrap = njit(cache=True)(wrap_pi_scalar)

# -------------------------------------------------------------------------------- motion


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
def cv_propagate(x, T: float, o0, o1, out) -> None:
    """Relative CV transition, L-R paper eqs. (1)-(3). Writes ``out``."""
    ax = x[0] + o0[0]
    ay = x[1] + o0[1]
    avx = x[2] + o0[2]
    avy = x[3] + o0[3]
    out[0] = ax + T * avx - o1[0]
    out[1] = ay + T * avy - o1[1]
    out[2] = avx - o1[2]
    out[3] = avy - o1[3]


@njit(cache=True)
def ct_propagate(x, T: float, o0, o1, out) -> None:
    """Relative CT transition with unknown turn rate, L-R paper eqs. (1), (5). Writes ``out``."""
    ax = x[0] + o0[0]
    ay = x[1] + o0[1]
    avx = x[2] + o0[2]
    avy = x[3] + o0[3]
    a, b, c, s = ct_coeffs(x[4], T)
    out[0] = ax + a * avx - b * avy - o1[0]
    out[1] = ay + b * avx + a * avy - o1[1]
    out[2] = c * avx - s * avy - o1[2]
    out[3] = s * avx + c * avy - o1[3]
    out[4] = x[4]


@njit(cache=True)
def cv_jacobian(T: float, F) -> None:
    """∂f/∂X of the CV model, L-R paper eq. (2). Writes ``F`` (4, 4)."""
    n = F.shape[0]
    for i in range(n):
        for j in range(n):
            F[i, j] = 1.0 if i == j else 0.0
    F[0, 2] = T
    F[1, 3] = T


@njit(cache=True)
def ct_jacobian(x, T: float, o0, F) -> None:
    """∂f/∂X of the CT model: eq. (5) plus the derivative with respect to ψ. Writes ``F``."""
    n = F.shape[0]
    for i in range(n):
        for j in range(n):
            F[i, j] = 1.0 if i == j else 0.0
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
def white_acceleration_noise(T: float, q1: float, q2: float, Q) -> None:
    """Process noise, L-R paper eq. (4) (4 × 4) and eq. (6) (5 × 5, ψ term q2 T). Writes ``Q``."""
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
    if n == 5:
        Q[4, 4] = q2 * T


@njit(cache=True)
def cv_propagate_points(X, T: float, o0, o1, Y) -> None:
    """:func:`cv_propagate` on every row of ``X``; writes the rows of ``Y``."""
    n = X.shape[1]
    yi = np.empty(n)
    for p in range(X.shape[0]):
        cv_propagate(X[p], T, o0, o1, yi)
        for i in range(n):
            Y[p, i] = yi[i]


@njit(cache=True)
def ct_propagate_points(X, T: float, o0, o1, Y) -> None:
    """:func:`ct_propagate` on every row of ``X``; writes the rows of ``Y`` (the same
    arithmetic, written out so that no row is staged through a temporary)."""
    for p in range(X.shape[0]):
        avx = X[p, 2] + o0[2]
        avy = X[p, 3] + o0[3]
        a, b, c, s = ct_coeffs(X[p, 4], T)
        Y[p, 0] = X[p, 0] + o0[0] + a * avx - b * avy - o1[0]
        Y[p, 1] = X[p, 1] + o0[1] + b * avx + a * avy - o1[1]
        Y[p, 2] = c * avx - s * avy - o1[2]
        Y[p, 3] = s * avx + c * avy - o1[3]
        Y[p, 4] = X[p, 4]


# ---------------------------------------------------------------------------- bearing


@njit(cache=True)
def bearing(x) -> float:
    """γ(X) = atan2(x, y), L-R paper eq. (7), rad."""
    return math.atan2(x[0], x[1])


@njit(cache=True)
def bearing_jacobian(x, H) -> None:
    """∂γ/∂X = [y/r², −x/r², 0, …] (eq. (7) differentiated). Writes row 0 of ``H``."""
    r2 = x[0] * x[0] + x[1] * x[1]
    for j in range(H.shape[1]):
        H[0, j] = 0.0
    H[0, 0] = x[1] / r2
    H[0, 1] = -x[0] / r2


@njit(cache=True)
def bearing_points(X, Z) -> None:
    """γ of every row of ``X`` into ``Z[:, 0]``."""
    for p in range(X.shape[0]):
        Z[p, 0] = math.atan2(X[p, 0], X[p, 1])


@njit(cache=True)
def mirrored_bearing_points(X, heading: float, Z) -> None:
    """Mirror bearing 2h − γ(X) (L-R paper eq. (8)), wrapped, of every row of ``X``."""
    for p in range(X.shape[0]):
        Z[p, 0] = wrap(2.0 * heading - math.atan2(X[p, 0], X[p, 1]))


@njit(cache=True, inline="always")
def bearing_loglik_term(dx: float, dy: float, s_th: float, c_th: float, it2: float) -> float:
    """(θ − atan2(dx, dy))² / 2σ² with the difference wrapped to (−π, π] as one atan2 of the
    rotated vector (SPL paper eqs. (9), (32)); ``s_th``, ``c_th`` = sin θ, cos θ,
    ``it2`` = 1 / 2σ²."""
    e = math.atan2(s_th * dy - c_th * dx, c_th * dy + s_th * dx)
    return e * e * it2


@njit(cache=True)
def bearing_loglik(rel, theta: float, sigma: float, ll) -> None:
    """Per-row bearing log-likelihood up to its constant, −(θ − γ)²/2σ², of relative states
    ``rel`` (N, ≥2); writes ``ll``."""
    s_th = math.sin(theta)
    c_th = math.cos(theta)
    it2 = 0.5 / (sigma * sigma)
    for i in range(rel.shape[0]):
        ll[i] = 0.0 - bearing_loglik_term(rel[i, 0], rel[i, 1], s_th, c_th, it2)


# --------------------------------------------------------------------------------- level


@njit(cache=True, inline="always")
def tl_interp(r: float, r0: float, dr: float, tl) -> float:
    """Linear interpolation of a uniform-grid TL profile (dB); held below the first range and
    continued by cylindrical spreading, TL(r_max) + 10 log10(r / r_max), beyond the last."""
    u = (r - r0) / dr
    if u <= 0.0:
        return tl[0]
    m = tl.shape[0] - 1
    if u >= m:
        rmax = r0 + m * dr
        return tl[m] + 10.0 * math.log10(r / rmax)
    j = int(u)
    f = u - j
    return tl[j] * (1.0 - f) + tl[j + 1] * f


@njit(cache=True, inline="always")
def tl_slope(r: float, r0: float, dr: float, tl) -> float:
    """dTL/dr (dB/m) of :func:`tl_interp`."""
    u = (r - r0) / dr
    if u <= 0.0:
        return 0.0
    m = tl.shape[0] - 1
    if u >= m:
        return 10.0 / (math.log(10.0) * r)
    j = int(u)
    return (tl[j + 1] - tl[j]) / dr


@njit(cache=True, inline="always")
def level(vx: float, vy: float, dx: float, dy: float, sl0: float, half_slope: float,
          vref2: float, r0: float, dr: float, tl) -> float:
    """Received level SL(v) − TL(r), dB re 1 µPa (SPL paper eqs. (12), (16)): source level
    sl0 + slope·log10(v / v_ref) at the absolute target speed v (v² floored at 1e-12),
    TL on the profile at the horizontal range r = |(dx, dy)|."""
    v2 = vx * vx + vy * vy
    if v2 < 1e-12:
        v2 = 1e-12
    return (sl0 + half_slope * math.log10(v2 / vref2)
            - tl_interp(math.sqrt(dx * dx + dy * dy), r0, dr, tl))


@njit(cache=True)
def level_bearing_points(X, own, sl_par, r0: float, dr: float, tl, Z) -> None:
    """[γ(X), level(X)] of every row of relative states ``X`` (SPL paper eqs. (9), (16));
    ``own`` the observer state [x, y, ẋ, ẏ] (the target's absolute velocity is X[2:4] + ẋ_o)."""
    half_slope = 0.5 * sl_par[1]
    vref2 = sl_par[2] * sl_par[2]
    for p in range(X.shape[0]):
        Z[p, 0] = math.atan2(X[p, 0], X[p, 1])
        Z[p, 1] = level(X[p, 2] + own[2], X[p, 3] + own[3], X[p, 0], X[p, 1], sl_par[0],
                        half_slope, vref2, r0, dr, tl)


@njit(cache=True)
def level_bearing_jacobian(x, own, sl_par, r0: float, dr: float, tl, H) -> None:
    """∂[γ, level]/∂X: bearing row as eq. (7); level row −dTL/dr · (x, y)/r for position and
    slope · v_a / (v² ln 10) for the absolute velocity v_a (eq. (12)). Writes ``H`` (2, n)."""
    n = H.shape[1]
    for i in range(2):
        for j in range(n):
            H[i, j] = 0.0
    r2 = x[0] * x[0] + x[1] * x[1]
    H[0, 0] = x[1] / r2
    H[0, 1] = -x[0] / r2
    r = math.sqrt(r2)
    g = tl_slope(r, r0, dr, tl)
    H[1, 0] = -g * x[0] / r
    H[1, 1] = -g * x[1] / r
    vx = x[2] + own[2]
    vy = x[3] + own[3]
    v2 = vx * vx + vy * vy
    if v2 >= 1e-12:
        k = sl_par[1] / (v2 * math.log(10.0))
        H[1, 2] = k * vx
        H[1, 3] = k * vy


@njit(cache=True, inline="always")
def level_loglik_term(vx: float, vy: float, dx: float, dy: float, lev: float, il2: float,
                      sl0: float, half_slope: float, vref2: float, r0: float, dr: float,
                      tl) -> float:
    """(l − SL(v) + TL(r))² / 2σ_l² (SPL paper eqs. (31)-(33)); ``il2`` = 1 / 2σ_l²."""
    e = lev - level(vx, vy, dx, dy, sl0, half_slope, vref2, r0, dr, tl)
    return e * e * il2


@njit(cache=True)
def level_bearing_loglik(rel, own, theta: float, lev: float, sigma: float, sigma_l: float,
                         sl_par, r0: float, dr: float, tl, ll) -> None:
    """Per-row bearing + level log-likelihood up to its constant (SPL paper eqs. (31)-(33)) of
    relative states ``rel`` (N, 4); writes ``ll``."""
    s_th = math.sin(theta)
    c_th = math.cos(theta)
    it2 = 0.5 / (sigma * sigma)
    il2 = 0.5 / (sigma_l * sigma_l)
    half_slope = 0.5 * sl_par[1]
    vref2 = sl_par[2] * sl_par[2]
    for i in range(rel.shape[0]):
        v = 0.0
        v -= bearing_loglik_term(rel[i, 0], rel[i, 1], s_th, c_th, it2)
        v -= level_loglik_term(rel[i, 2] + own[2], rel[i, 3] + own[3], rel[i, 0], rel[i, 1],
                               lev, il2, sl_par[0], half_slope, vref2, r0, dr, tl)
        ll[i] = v
