"""Numba kernel of the narrowband EKF (thesis eqs. (3.21)-(3.23)): predict and update, sample by
sample, over a span of samples between two re-initialisations.

The update is the information form of the EKF: with ``H`` the (M, 2) Jacobian and ``R = diag(r)``
(M = N_H real, or 2 N_H for baseband Re/Im),

    P⁺⁻¹ = P⁻⁻¹ + Hᵀ R⁻¹ H,        x⁺ = x⁻ + P⁺ Hᵀ R⁻¹ (y − h(x⁻)),

so only 2 × 2 matrices are inverted, never the N_H × N_H innovation covariance of the usual
gain form. The sums over elements are accumulated in one pass. The plain numpy reference of
the same equations is in ``tests/stages/narrowband/reference.py``. Written by hand: no
maintained library runs an EKF on a per-sample array measurement at this rate.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

TWO_PI = 2.0 * math.pi


@njit(cache=True, nogil=True)
def ekf_span(yr: np.ndarray, yi: np.ndarray, cplx: bool, tau0: float, dt: float, speed: float,
             x: np.ndarray, c: float, mix0: float, mix_step: float, rinv: np.ndarray,
             q: np.ndarray,
             state: np.ndarray, cov: np.ndarray, out: np.ndarray,
             uniform: bool = False, beta: float = 1.0) -> None:
    """Run the EKF over ``T`` samples, updating ``state`` (θ rad, f Hz) and ``cov`` (2, 2) in
    place and writing ``out[k] = (θ, f, P_θθ, P_ff)`` after each sample's update.

    ``yr``/``yi``: (T, N) real and imaginary parts (``yi`` unused when ``cplx`` is False);
    sample k is at ``τ = tau0 + k dt`` s since the filter's (re)initialisation and has the
    mixing phase ``mix0 + k mix_step`` rad (complex input); ``rinv`` (N,)
    inverse noise variance of each real measurement component; ``q`` (2,) process noise
    variance per second of θ (rad²/s) and f (Hz²/s). ``uniform``: the elements are equally
    spaced in ``x`` order, so the element phasors follow from the first by a constant rotation
    (one complex product per element instead of a sine and a cosine). ``beta`` = 1 applies
    the own-speed Doppler factor to the element delay term as in thesis eq. (3.18); 0 applies
    it to the time term only (see :mod:`.model`).
    """
    n_t, n = yr.shape
    th, f = state[0], state[1]
    p00, p01, p11 = cov[0, 0], cov[0, 1], cov[1, 1]
    for k in range(n_t):
        tau = tau0 + k * dt
        # predict (Φ = I, thesis eq. (3.22))
        p00 += q[0] * dt
        p11 += q[1] * dt
        ct = math.cos(th)
        st = math.sin(th)
        a = 1.0 + speed * ct / c
        b = 1.0 + beta * speed * ct / c
        wf = TWO_PI * f
        gt0 = -TWO_PI * f * st / c
        j00 = 0.0
        j01 = 0.0
        j11 = 0.0
        b0 = 0.0
        b1 = 0.0
        zr = zi = rr = ri = 0.0
        if uniform:
            ps0 = wf * (a * tau + b * x[0] * ct / c)
            if cplx:
                ps0 -= mix0 + k * mix_step
            zr = math.cos(ps0)
            zi = math.sin(ps0)
            dph = wf * b * (x[1] - x[0]) * ct / c if n > 1 else 0.0
            rr = math.cos(dph)
            ri = math.sin(dph)
        for m in range(n):
            s = a * tau + b * x[m] * ct / c
            gth = gt0 * (speed * tau + b * x[m] + beta * speed * x[m] * ct / c)
            gf = TWO_PI * s
            if uniform:
                cs = zr
                sn = zi
                zr, zi = zr * rr - zi * ri, zr * ri + zi * rr
            elif cplx:
                ps = wf * s - (mix0 + k * mix_step)
                cs = math.cos(ps)
                sn = math.sin(ps)
            else:
                cs = math.cos(wf * s)
                sn = math.sin(wf * s)
            if cplx:
                # residual along the model's tangent: Im(y e^{-jΨ}); |∂h|² = |∇Φ|²
                e = (yi[k, m] * cs - yr[k, m] * sn) * rinv[m]
                w = rinv[m]
            else:
                e = cs * (yr[k, m] - sn) * rinv[m]
                w = cs * cs * rinv[m]
            j00 += w * gth * gth
            j01 += w * gth * gf
            j11 += w * gf * gf
            b0 += e * gth
            b1 += e * gf
        # information form: (P⁻)⁻¹ + J, then invert the 2 x 2
        det = p00 * p11 - p01 * p01
        i00 = p11 / det + j00
        i01 = -p01 / det + j01
        i11 = p00 / det + j11
        det = i00 * i11 - i01 * i01
        p00 = i11 / det
        p01 = -i01 / det
        p11 = i00 / det
        th += p00 * b0 + p01 * b1
        f += p01 * b0 + p11 * b1
        th = th % TWO_PI
        if th > math.pi:
            th = TWO_PI - th
            p01 = -p01
        out[k, 0] = th
        out[k, 1] = f
        out[k, 2] = p00
        out[k, 3] = p11
    state[0] = th
    state[1] = f
    cov[0, 0] = p00
    cov[0, 1] = p01
    cov[1, 0] = p01
    cov[1, 1] = p11
