"""Numba kernels of the regularized particle filter (SPL paper section 4, Musso et al. 2001).

State per particle: absolute target state [x, y, vx, vy] (m, m/s); the observer track is known
and deterministic, so this is the paper's relative-state recursion eq. (4) shifted by the
observer state. All angles are radians.

Random numbers come from a counter-based SplitMix64 stream per Monte Carlo run (state: one
uint64), so results are bit-identical whatever the number of threads, and a plain-numpy
implementation can regenerate exactly the same draws (``splitmix64_block`` in the tests). The
draw order is part of the contract:

* uniform: one SplitMix64 output, ``((z >> 11) + 1) · 2⁻⁵³`` ∈ (0, 1]
* normal pair: Marsaglia's polar method, tries of two uniforms (u, v) ↦ (2u − 1, 2v − 1)
* prior (per particle): normal pair (range, bearing), normal pair (speed, course)
* propagation (per particle): one normal pair (a_x, a_y)
* systematic resampling: one uniform; multinomial: N + 1 exponentials ``−ln u``
* regularization (per particle): two points of the unit disc (tries of two uniforms), then
  three uniforms (see :func:`rand_epanechnikov4`)
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from arrayproc.track.models._kernels import bearing_loglik_term, level_loglik_term

GOLDEN = np.uint64(0x9E3779B97F4A7C15)
MIX1 = np.uint64(0xBF58476D1CE4E5B9)
MIX2 = np.uint64(0x94D049BB133111EB)
S30 = np.uint64(30)
S27 = np.uint64(27)
S31 = np.uint64(31)
S11 = np.uint64(11)
TWO53 = 1.0 / 9007199254740992.0
NX = 4
# Epanechnikov kernel in R^4: unit-ball volume c_4 = π²/2; A(K) of SPL paper eq. (28)
C_NX = math.pi**2 / 2.0
A_K = (8.0 / C_NX * (NX + 4) * (2.0 * math.sqrt(math.pi)) ** NX) ** (1.0 / (NX + 4))


@njit(cache=True, inline="always")
def _next_u64(state):
    state[0] += GOLDEN
    z = state[0]
    z = (z ^ (z >> S30)) * MIX1
    z = (z ^ (z >> S27)) * MIX2
    return z ^ (z >> S31)


@njit(cache=True, inline="always")
def rand_uniform(state) -> float:
    """One uniform in (0, 1] from the SplitMix64 stream ``state`` (uint64[1], advanced)."""
    return (float(_next_u64(state) >> S11) + 1.0) * TWO53


@njit(cache=True, inline="always")
def rand_normal_pair(state):
    """Two independent N(0, 1) by Marsaglia's polar method: u, v = 2U − 1 (two uniforms per
    try) until 0 < s = u² + v² < 1, then (u, v)·√(−2 ln s / s)."""
    while True:
        u = 2.0 * rand_uniform(state) - 1.0
        v = 2.0 * rand_uniform(state) - 1.0
        q = u * u + v * v
        if 0.0 < q < 1.0:
            f = math.sqrt(-2.0 * math.log(q) / q)
            return u * f, v * f


@njit(cache=True, inline="always")
def rand_disc(state):
    """A point uniform in the unit disc (two uniforms per try) and its squared norm."""
    while True:
        u = 2.0 * rand_uniform(state) - 1.0
        v = 2.0 * rand_uniform(state) - 1.0
        q = u * u + v * v
        if 0.0 < q < 1.0:
            return u, v, q


@njit(cache=True, inline="always")
def rand_epanechnikov4(state):
    """A draw from the 4-D Epanechnikov kernel, SPL paper eq. (26).

    Direction uniform on the unit 3-sphere by Marsaglia (1972): two points of the unit disc
    (x1, x2; q1) and (x3, x4; q2) give (x1, x2, x3 t, x4 t), t = √((1 − q1)/q2). The squared
    radius is Beta(n_x/2, 2) = Beta(2, 2), the median of three uniforms.
    """
    x1, x2, q1 = rand_disc(state)
    x3, x4, q2 = rand_disc(state)
    t = math.sqrt((1.0 - q1) / q2)
    u1 = rand_uniform(state)
    u2 = rand_uniform(state)
    u3 = rand_uniform(state)
    med = max(min(u1, u2), min(max(u1, u2), u3))
    r = math.sqrt(med)
    return x1 * r, x2 * r, x3 * t * r, x4 * t * r


@njit(cache=True)
def uniform_block(state, n):
    """``n`` uniforms from the stream (for tests and small draws)."""
    out = np.empty(n)
    for i in range(n):
        out[i] = rand_uniform(state)
    return out


@njit(cache=True)
def normal_block(state, n_pairs):
    """``n_pairs`` normal pairs (n_pairs, 2) from the stream (tests, small draws)."""
    out = np.empty((n_pairs, 2))
    for i in range(n_pairs):
        out[i, 0], out[i, 1] = rand_normal_pair(state)
    return out


@njit(cache=True)
def epanechnikov_block(state, n):
    """``n`` draws (n, 4) from the 4-D Epanechnikov kernel (tests)."""
    out = np.empty((n, NX))
    for i in range(n):
        out[i, 0], out[i, 1], out[i, 2], out[i, 3] = rand_epanechnikov4(state)
    return out


@njit(cache=True)
def init_polar_prior(parts, state, obs_x, obs_y, bearing0, sig_bearing, range_mean, range_std,
                     speed_mean, speed_std, course_mean, course_std, min_range,
                     course_uniform=False):
    """Draw the prior of Ristic et al. 2003 ch. 6.4.1.1 (SPL paper section 5): range, bearing
    and speed Gaussian; course Gaussian, or with ``course_uniform`` uniform with the same mean
    and standard deviation (course_mean ± √3·course_std: ± 90° for the paper's π/√12, the
    standard deviation of a uniform over a half circle). Absolute positions and velocities."""
    n = parts.shape[0]
    half = math.sqrt(3.0) * course_std
    for i in range(n):
        zr, zb = rand_normal_pair(state)
        zs, zc = rand_normal_pair(state)
        r = range_mean + range_std * zr
        if r < min_range:
            r = min_range
        b = bearing0 + sig_bearing * zb
        s = speed_mean + speed_std * zs
        if course_uniform:
            c = course_mean + half * (2.0 * rand_uniform(state) - 1.0)
        else:
            c = course_mean + course_std * zc
        parts[i, 0] = obs_x + r * math.sin(b)
        parts[i, 1] = obs_y + r * math.cos(b)
        parts[i, 2] = s * math.sin(c)
        parts[i, 3] = s * math.cos(c)


@njit(cache=True)
def propagate_cv(parts, state, dt, sigma_a):
    """Constant-velocity prediction of every particle, SPL paper eqs. (4)-(6), (17):
    x ← F x + Γ ν, ν ~ N(0, σ_a² I₂) (one normal pair per particle). Skipped when ``dt`` ≤ 0."""
    if dt > 0.0:
        h = 0.5 * dt * dt
        for i in range(parts.shape[0]):
            ax, ay = rand_normal_pair(state)
            ax *= sigma_a
            ay *= sigma_a
            parts[i, 0] += dt * parts[i, 2] + h * ax
            parts[i, 1] += dt * parts[i, 3] + h * ay
            parts[i, 2] += dt * ax
            parts[i, 3] += dt * ay


@njit(cache=True)
def max_finite(ll):
    """Largest value of ``ll`` (−inf if none)."""
    m = -np.inf
    for i in range(ll.shape[0]):
        if ll[i] > m:
            m = ll[i]
    return m


@njit(cache=True)
def predict_loglik(parts, ll, state, dt, sigma_a, obs_x, obs_y, theta, sig_theta, level,
                   sig_level, use_theta, use_level, sl_par, tl_r0, tl_dr, tl):
    """Prediction (:func:`propagate_cv`) and log-likelihood of every absolute particle for the
    fused Monte Carlo kernel; returns the max log-likelihood.

    Log-likelihood up to a constant, SPL paper eqs. (31)-(33): the bearing term
    (eqs. (9), (32)) and the level term with SL(v) of eq. (12) and TL linearly interpolated in
    range (eqs. (13), (16)) — the kernels of the bearing and level measurement models
    (:mod:`arrayproc.track.models._kernels`).
    """
    n = parts.shape[0]
    it2 = 0.5 / (sig_theta * sig_theta)
    il2 = 0.5 / (sig_level * sig_level)
    sl0 = sl_par[0]
    half_slope = 0.5 * sl_par[1]
    vref2 = sl_par[2] * sl_par[2]
    s_th = math.sin(theta)
    c_th = math.cos(theta)
    llmax = -np.inf
    propagate_cv(parts, state, dt, sigma_a)
    for i in range(n):
        dx = parts[i, 0] - obs_x
        dy = parts[i, 1] - obs_y
        v = 0.0
        if use_theta:
            v -= bearing_loglik_term(dx, dy, s_th, c_th, it2)
        if use_level:
            v -= level_loglik_term(parts[i, 2], parts[i, 3], dx, dy, level, il2, sl0,
                                   half_slope, vref2, tl_r0, tl_dr, tl)
        ll[i] = v
        if v > llmax:
            llmax = v
    return llmax


@njit(cache=True)
def _moments(parts, w, s, mean, cov):
    """Weighted mean and covariance, SPL paper eqs. (29)-(30), weights w / s (one pass,
    shifted by the first particle to avoid cancellation)."""
    n = parts.shape[0]
    c0, c1, c2, c3 = parts[0, 0], parts[0, 1], parts[0, 2], parts[0, 3]
    m = np.zeros(NX)
    q = np.zeros((NX, NX))
    d = np.empty(NX)
    for i in range(n):
        wi = w[i]
        d[0] = parts[i, 0] - c0
        d[1] = parts[i, 1] - c1
        d[2] = parts[i, 2] - c2
        d[3] = parts[i, 3] - c3
        for a in range(NX):
            wa = wi * d[a]
            m[a] += wa
            for b in range(a, NX):
                q[a, b] += wa * d[b]
    mean[0] = c0 + m[0] / s
    mean[1] = c1 + m[1] / s
    mean[2] = c2 + m[2] / s
    mean[3] = c3 + m[3] / s
    for a in range(NX):
        for b in range(a, NX):
            cov[a, b] = q[a, b] / s - (m[a] / s) * (m[b] / s)
            cov[b, a] = cov[a, b]


@njit(cache=True)
def reweight(w, s_old, ll, llmax, out):
    """Weight update, SPL paper eqs. (18)-(20): out_i = (w_i / s_old)·exp(ll_i − max ll).

    Weights are kept unnormalised with their sum (normalisation eq. (19) is the division by
    the returned sum ``s``); returns ``(s, N_eff)`` with N_eff = 1 / Σ (out_i/s)² = s² / Σ out_i².
    If every product underflows, the update is redone exactly in the log domain.
    """
    n = w.shape[0]
    s = 0.0
    s2 = 0.0
    inv = 1.0 / s_old
    for i in range(n):
        wi = w[i] * inv * math.exp(ll[i] - llmax)
        out[i] = wi
        s += wi
        s2 += wi * wi
    if not s > 1e-280:
        m = -np.inf
        for i in range(n):
            if w[i] > 0.0:
                m = max(m, math.log(w[i] / s_old) + ll[i])
        s = 0.0
        s2 = 0.0
        for i in range(n):
            wi = math.exp(math.log(w[i] / s_old) + ll[i] - m) if w[i] > 0.0 else 0.0
            out[i] = wi
            s += wi
            s2 += wi * wi
    return s, s * s / s2


@njit(cache=True)
def systematic_resample(w, s, idx, state):
    """Systematic resampling: one uniform u, points (j + 1 − u)/N, j = 0..N−1, against the
    cumulative normalised weights; ancestors in ``idx``."""
    n = w.shape[0]
    u = rand_uniform(state)
    c = w[0] / s
    k = 0
    for j in range(n):
        p = (j + 1.0 - u) / n
        while p > c and k < n - 1:
            k += 1
            c += w[k] / s
        idx[j] = k


@njit(cache=True)
def multinomial_resample(w, s, idx, state):
    """Multinomial resampling (the paper's draw): N sorted uniforms from N + 1 exponential
    spacings −ln u, merged against the cumulative normalised weights in one pass."""
    n = w.shape[0]
    e = np.empty(n + 1)
    tot = 0.0
    for j in range(n + 1):
        e[j] = -math.log(rand_uniform(state))
        tot += e[j]
    acc = 0.0
    c = w[0] / s
    k = 0
    for j in range(n):
        acc += e[j]
        p = acc / tot
        while p > c and k < n - 1:
            k += 1
            c += w[k] / s
        idx[j] = k


CHOL_JITTER = 1e-10


@njit(cache=True)
def cholesky4(p, d):
    """Lower Cholesky factor D of a 4×4 covariance, D Dᵀ = P + δ·diag(P), δ = 1e-10
    (SPL paper eq. (21), P_k = D_k D_kᵀ).

    Factorised on the correlation matrix (unit diagonal) with the jitter δ, then scaled back,
    so a rank-deficient cloud (e.g. all particles on a line) gives a bounded factor,
    |D_ij| ≤ √((1 + δ) P_ii), instead of dividing by a rounding-error pivot. A dimension with
    zero variance gets a zero row. Returns False if P is not finite.
    """
    sc = np.empty(NX)
    for a in range(NX):
        if not math.isfinite(p[a, a]):
            return False
        sc[a] = math.sqrt(p[a, a]) if p[a, a] > 0.0 else 0.0
    for a in range(NX):
        for b in range(NX):
            d[a, b] = 0.0
    for j in range(NX):
        if sc[j] == 0.0:
            continue
        s = 1.0 + CHOL_JITTER
        for k in range(j):
            s -= d[j, k] * d[j, k]
        if s < 0.5 * CHOL_JITTER:
            s = 0.5 * CHOL_JITTER
        d[j, j] = math.sqrt(s)
        for i in range(j + 1, NX):
            if sc[i] == 0.0:
                continue
            c = p[i, j] / (sc[i] * sc[j])
            if not math.isfinite(c):
                return False
            for k in range(j):
                c -= d[i, k] * d[j, k]
            d[i, j] = c / d[j, j]
    for i in range(NX):
        for j in range(i + 1):
            d[i, j] *= sc[i]
    return True


@njit(cache=True)
def regularise(parts, src, idx, dmat, h, state):
    """SPL paper eq. (21): x_i = x́_i + h D ε_i, x́_i = src[idx_i], ε_i ~ Epanechnikov
    (eq. (26), :func:`rand_epanechnikov4`)."""
    n = parts.shape[0]
    for i in range(n):
        e0, e1, e2, e3 = rand_epanechnikov4(state)
        a = idx[i]
        for r in range(NX):
            parts[i, r] = src[a, r] + h * (dmat[r, 0] * e0 + dmat[r, 1] * e1
                                           + dmat[r, 2] * e2 + dmat[r, 3] * e3)


@njit(cache=True)
def speed_gate(parts, w, ll, v_max, llmax, ovx=0.0, ovy=0.0):
    """Hard speed constraint: particles whose speed ‖(ẋ, ẏ)‖ exceeds ``v_max`` (m/s) get zero
    likelihood (``ll`` = −inf), unless that would leave no particle of positive weight ``w``,
    in which case nothing changes. ``v_max`` ≤ 0 switches it off. ``ovx``, ``ovy``: a velocity
    added to the particles' (relative particles: the observer's). Returns the new maximum of
    ``ll``. Not in the SPL paper: the optional prior knowledge of a maximum target speed
    (docs/validation.md, Tracking II)."""
    if v_max <= 0.0:
        return llmax
    n = parts.shape[0]
    v2 = v_max * v_max
    keep = 0
    for i in range(n):
        vx = parts[i, 2] + ovx
        vy = parts[i, 3] + ovy
        if w[i] > 0.0 and vx * vx + vy * vy <= v2:
            keep += 1
    if keep == 0:
        return llmax
    m = -np.inf
    for i in range(n):
        vx = parts[i, 2] + ovx
        vy = parts[i, 3] + ovy
        if vx * vx + vy * vy > v2:
            ll[i] = -np.inf
        elif ll[i] > m:
            m = ll[i]
    return m


@njit(cache=True)
def bandwidth(n):
    """MISE-optimal bandwidth h = A(K) N^(−1/(n_x+4)), SPL paper eqs. (27)-(28), n_x = 4."""
    return A_K * n ** (-1.0 / (NX + 4))


@njit(cache=True)
def _resample_regularise(parts, w, s, idx, src, dmat, h, state, resample_method):
    """Resample (systematic or multinomial) and jitter with the Epanechnikov kernel (SPL paper
    eqs. (21)-(28)); weights become uniform. Returns the new weight sum, N."""
    if resample_method == 0:
        systematic_resample(w, s, idx, state)
    else:
        multinomial_resample(w, s, idx, state)
    src[:, :] = parts
    regularise(parts, src, idx, dmat, h, state)
    w[:] = 1.0
    return float(parts.shape[0])


@njit(cache=True)
def rpf_run(theta, level, use_theta0, use_level, times, obs, seed, n_particles, n_thr,
            sigma_a, sig_theta, sig_level, prior, sl_par, tl_r0, tl_dr, tl, resample_method,
            h_scale, est, cov, resampled):
    """One RPF run over all measurement times (SPL paper section 4).

    ``prior`` = [range_mean, range_std, speed_mean, speed_std, course_offset, course_std,
    min_range(, course_uniform, v_max)]; the prior bearing is θ₀ and the course mean θ₀ +
    course_offset; ``course_uniform`` (1/0, default 0) draws the course uniformly (see
    :func:`init_polar_prior`) and ``v_max`` (m/s, default 0 = none) applies
    :func:`speed_gate` at every weighting. At k = 0 the
    particles are drawn from the prior (which already uses θ₀) and weighted by l₀ if levels are
    used (and by θ₀ if ``use_theta0``); from k = 1: prediction, update, regularization-
    resampling when N_eff < N_thr·N (D from the weighted covariance before resampling), and
    the estimate after that step (SPL paper section 4.4). ``sl_par`` = [sl0, slope, v_ref].
    ``h_scale`` multiplies the MISE-optimal bandwidth (1 in the paper).
    Outputs: ``est`` (K, 4), ``cov`` (K, 4, 4), ``resampled`` (K,) flags.
    """
    k_n = times.shape[0]
    n = n_particles
    state = np.empty(1, dtype=np.uint64)
    state[0] = seed
    parts = np.empty((n, NX))
    src = np.empty((n, NX))
    w = np.ones(n)
    w_new = np.empty(n)
    s = float(n)
    ll = np.empty(n)
    idx = np.empty(n, dtype=np.int64)
    mean = np.empty(NX)
    pcov = np.empty((NX, NX))
    dmat = np.empty((NX, NX))
    h = h_scale * bandwidth(n)
    course_uniform = prior.shape[0] > 7 and prior[7] != 0.0
    v_max = prior[8] if prior.shape[0] > 8 else 0.0
    init_polar_prior(parts, state, obs[0, 0], obs[0, 1], theta[0], sig_theta, prior[0],
                     prior[1], prior[2], prior[3], theta[0] + prior[4], prior[5], prior[6],
                     course_uniform)
    for k in range(k_n):
        dt = times[k] - times[k - 1] if k > 0 else 0.0
        ut = use_theta0 or k > 0
        neff = float(n)
        if ut or use_level:
            llmax = predict_loglik(parts, ll, state, dt, sigma_a, obs[k, 0], obs[k, 1],
                                   theta[k], sig_theta, level[k], sig_level, ut, use_level,
                                   sl_par, tl_r0, tl_dr, tl)
            llmax = speed_gate(parts, w, ll, v_max, llmax)
            s, neff = reweight(w, s, ll, llmax, w_new)
            w, w_new = w_new, w
        elif dt > 0.0:
            predict_loglik(parts, ll, state, dt, sigma_a, obs[k, 0], obs[k, 1], theta[k],
                           sig_theta, level[k], sig_level, False, False, sl_par, tl_r0, tl_dr,
                           tl)
        _moments(parts, w, s, mean, pcov)
        resampled[k] = False
        if neff < n_thr * n and cholesky4(pcov, dmat):
            s = _resample_regularise(parts, w, s, idx, src, dmat, h, state, resample_method)
            resampled[k] = True
            _moments(parts, w, s, mean, pcov)
        est[k, :] = mean
        cov[k, :, :] = pcov


@njit(cache=True)
def rpf_correct(parts, w, w_new, s, ll, state, n_thr, resample_method, h, idx, src, mean, pcov,
                dmat, v_max, ovx, ovy):
    """Weighting and regularization-resampling of one RPF cycle for a step-by-step filter, from
    the particles' log-likelihoods ``ll`` (any measurement model): speed gate
    (:func:`speed_gate`), reweighting (eqs. (18)-(20)), moments (eqs. (29)-(30)) and, if
    N_eff < N_thr·N, resampling with Epanechnikov jitter (eqs. (21)-(28)). Same kernels and
    draw order as :func:`rpf_run`. Returns ``(s, log Σ (w_i/s_old)·exp(ll_i), resampled)``; the
    caller adds the measurement's normalising constant to get log p(z | past)."""
    n = parts.shape[0]
    llmax = max_finite(ll)
    llmax = speed_gate(parts, w, ll, v_max, llmax, ovx, ovy)
    s, neff = reweight(w, s, ll, llmax, w_new)
    w[:] = w_new
    logev = llmax + math.log(s)
    _moments(parts, w, s, mean, pcov)
    done = False
    if neff < n_thr * n and cholesky4(pcov, dmat):
        s = _resample_regularise(parts, w, s, idx, src, dmat, h, state, resample_method)
        done = True
        _moments(parts, w, s, mean, pcov)
    return s, logev, done


@njit(cache=True, parallel=True)
def rpf_monte_carlo(theta, level, use_theta0, use_level, times, obs, seeds, n_particles, n_thr,
                    sigma_a, sig_theta, sig_level, prior, sl_par, tl_r0, tl_dr, tl,
                    resample_method, h_scale, est, cov, resampled):
    """``rpf_run`` for every run r (rows of ``theta``, ``level``, ``seeds``), parallel over runs.

    Each run has its own seed, so the result does not depend on the thread count.
    """
    for r in prange(theta.shape[0]):
        rpf_run(theta[r], level[r], use_theta0, use_level, times, obs, seeds[r], n_particles,
                n_thr, sigma_a, sig_theta, sig_level, prior, sl_par, tl_r0, tl_dr, tl,
                resample_method, h_scale, est[r], cov[r], resampled[r])
