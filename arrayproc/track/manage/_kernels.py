"""Numba kernels of the left-right resolution (L-R paper eqs. (9)-(13)) and the fused L-R
Monte Carlo kernel.

:func:`lr_normalise` (eqs. (10)-(11)) and :func:`lr_combine` (eqs. (12)-(13)) are the one
implementation of the L-R weights and combination: :class:`arrayproc.track.manage.lr.LRResolver`
calls them step by step for any filter and measurement model, and :func:`run_track` inlines
them. :func:`run_track` / :func:`run_montecarlo` are the specialised fast path of the Monte
Carlo evaluation: CV (n = 4) or CT (n = 5) motion, bearing measurements (L-R paper eq. (7)),
the Gaussian filters' kernels of :mod:`arrayproc.track.filters._kernels` composed in one
compiled loop.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from arrayproc.track._kernels import init_from_bearing
from arrayproc.track.filters._kernels import (
    ekf_predict,
    ekf_update,
    sp_predict_moments,
    sp_predict_points,
    sp_update_correct,
    sp_update_points,
    srf_update,
)
from arrayproc.track.models._kernels import (
    bearing,
    bearing_jacobian,
    bearing_points,
    ct_jacobian,
    ct_propagate,
    ct_propagate_points,
    cv_jacobian,
    cv_propagate,
    cv_propagate_points,
    white_acceleration_noise,
)

# filter kinds of the fused kernel (see arrayproc.track.manage.lr.fused_kind)
KIND_EKF = 0
KIND_SP = 1
KIND_SRF = 2  # shifted Rayleigh, likelihood of the L-R paper section IV
KIND_SRF_EXACT = 3  # shifted Rayleigh, exact (projected normal) bearing likelihood


@njit(cache=True)
def lr_normalise(logw, alive) -> bool:
    """ω_k^h ∝ p_k^h ω_{k−1}^h normalised (eqs. (10)-(11)) in the log domain, in place; dead
    hypotheses get −inf. ``logw`` already holds log ω_{k−1} + log p_k. Returns False when every
    hypothesis is dead."""
    m = logw.shape[0]
    mx = -np.inf
    for h in range(m):
        if alive[h] and logw[h] > mx:
            mx = logw[h]
    if mx == -np.inf:
        return False
    tot = 0.0
    for h in range(m):
        tot += math.exp(logw[h] - mx) if alive[h] else 0.0
    lt = mx + math.log(tot)
    for h in range(m):
        logw[h] = logw[h] - lt if alive[h] else -np.inf
    return True


@njit(cache=True)
def lr_combine(X, P, logw, alive, x_out, P_out, w_out) -> None:
    """Weights w_out = ω^h (eqs. (10)-(11)), combined estimate x_out = Σ ω^h x^h (eq. (12)) and
    covariance P_out = Σ ω^h (P^h + (x^h − x)(x^h − x)ᵀ) (eq. (13)) of hypotheses X (m, n),
    P (m, n, n)."""
    m = X.shape[0]
    n = x_out.shape[0]
    for i in range(n):
        x_out[i] = 0.0
    for h in range(m):
        w = math.exp(logw[h]) if alive[h] else 0.0
        w_out[h] = w
        if w > 0.0:
            for i in range(n):
                x_out[i] += w * X[h, i]
    for i in range(n):
        for j in range(n):
            P_out[i, j] = 0.0
    for h in range(m):
        w = w_out[h]
        if w > 0.0:
            for i in range(n):
                di = X[h, i] - x_out[i]
                for j in range(n):
                    P_out[i, j] += w * (P[h, i, j] + di * (X[h, j] - x_out[j]))


@njit(cache=True)
def _predict(kind: int, x, P, T: float, o0, o1, q1: float, q2: float, Upred, wmpred, wcpred,
             Xs, Y, F, xn, Q) -> int:
    """Time update of the fused kernel: EKF (and SRF on CV, exact linear) or sample points."""
    n = x.shape[0]
    white_acceleration_noise(T, q1, q2, Q)
    if kind == KIND_EKF or (kind >= KIND_SRF and n == 4):
        if n == 4:
            cv_jacobian(T, F)
            cv_propagate(x, T, o0, o1, xn)
        else:
            ct_jacobian(x, T, o0, F)
            ct_propagate(x, T, o0, o1, xn)
        return ekf_predict(x, P, F, xn, Q)
    st = sp_predict_points(x, P, Upred, Xs)
    if st < 0:
        return -1
    if n == 4:
        cv_propagate_points(Xs, T, o0, o1, Y)
    else:
        ct_propagate_points(Xs, T, o0, o1, Y)
    return sp_predict_moments(x, P, Y, Q, wmpred, wcpred, st)


@njit(cache=True)
def _update_bearing(kind: int, x, P, z: float, sigma: float, U, wm, wc, Xs, Zs, L, zv, zp, H,
                    R, ang):
    """Bearing update (eq. (7)) of the fused kernel; returns (log-likelihood, status)."""
    if kind >= KIND_SRF:
        return srf_update(x, P, z, sigma, kind == KIND_SRF_EXACT)
    zv[0] = z
    R[0, 0] = sigma * sigma
    if kind == KIND_EKF:
        zp[0] = bearing(x)
        bearing_jacobian(x, H)
        return ekf_update(x, P, zv, zp, H, R, ang)
    st = sp_update_points(x, P, U, Xs, L, 2)  # the bearing reads x, y
    if st < 0:
        return -np.inf, -1
    bearing_points(Xs, Zs)
    return sp_update_correct(x, P, L, zv, Zs, R, ang, U, wm, wc, st)


@njit(cache=True)
def run_track(kind: int, n_hyp: int, times, zs, own, sigma: float, q1: float, q2: float, prior,
              init_draw, U, wm, wc, Upred, wmpred, wcpred, xs_out, Ps_out, w_out):
    """Run one filter (``n_hyp`` = 1) or the two-hypothesis L-R scheme (``n_hyp`` = 2,
    eqs. (9)-(13)) over one sequence of bearings.

    times (K,), zs (K, n_hyp) bearings in rad (column h feeds hypothesis h), own (K, 4)
    observer states, prior = [r̄, σr, s̄, σs, σθ, σc, σψ], init_draw = (r0, s0, dc) the
    initial range, speed and course offset of the mean (see
    :func:`arrayproc.track._kernels.init_from_bearing`). The state dimension of ``xs_out``
    (K, n) picks the motion model: 4 CV, 5 CT. Writes the combined estimate ``xs_out``
    (eq. (12)), its covariance ``Ps_out`` (K, n, n) (eq. (13)) and the weights ``w_out``
    (K, n_hyp) (eqs. (10)-(11)). Returns a status: bit 1 a covariance was repaired, bit 2 a
    hypothesis diverged (its weight is set to zero), bit 4 every hypothesis diverged (the
    estimate is then frozen at its last finite value).
    """
    n = xs_out.shape[1]
    K = times.shape[0]
    X = np.empty((n_hyp, n))
    P = np.empty((n_hyp, n, n))
    logw = np.empty(n_hyp)
    alive = np.ones(n_hyp, dtype=np.bool_)
    # work arrays of the filter kernels
    Y = np.empty((Upred.shape[0], n))
    Xp = np.empty((Upred.shape[0], n))
    Zs = np.empty((U.shape[0], 1))
    Xu = np.empty((U.shape[0], n))
    F = np.empty((n, n))
    xn = np.empty(n)
    Q = np.empty((n, n))
    L = np.empty((n, n))
    zv = np.empty(1)
    zp = np.empty(1)
    H = np.empty((1, n))
    R = np.empty((1, 1))
    ang = np.ones(1, dtype=np.bool_)
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
                st = _predict(kind, X[h], P[h], T, own[k - 1], own[k], q1, q2, Upred, wmpred,
                              wcpred, Xp, Y, F, xn, Q)
                ll = 0.0
                if st >= 0:
                    ll, st2 = _update_bearing(kind, X[h], P[h], zs[k, h], sigma, U, wm, wc,
                                              Xu, Zs, L, zv, zp, H, R, ang)
                    st = -1 if st2 < 0 else max(st, st2)
                if st < 0:
                    alive[h] = False
                    logw[h] = -np.inf
                    status |= 2
                else:
                    if st > 0:
                        status |= 1
                    logw[h] += ll
            if not lr_normalise(logw, alive):
                status |= 4
                for kk in range(k, K):
                    xs_out[kk] = xs_out[k - 1]
                    Ps_out[kk] = Ps_out[k - 1]
                    w_out[kk] = w_out[k - 1]
                return status
        lr_combine(X, P, logw, alive, xs_out[k], Ps_out[k], w_out[k])
    return status


@njit(cache=True, nogil=True)
def run_montecarlo(kind: int, n_hyp: int, times, zs, own, sigma: float, q1: float, q2: float,
                   prior, init_draws, U, wm, wc, Upred, wmpred, wcpred, n: int, est, wts, Pfin,
                   status) -> None:
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
        status[r] = run_track(kind, n_hyp, times, zs[r], own, sigma, q1, q2, prior,
                              init_draws[r], U, wm, wc, Upred, wmpred, wcpred, xs, Ps, ws)
        est[r] = xs[:, :4]
        wts[r] = ws
        Pfin[r] = Ps[K - 1]
