"""Numba kernels of the batch TMA objectives (thesis eqs. (3.47), (3.52); compact-array paper
eq. (4)).

Each kernel evaluates a least-squares cost for many parameter vectors at once: a
differential-evolution population (``vectorized=True``) or a grid. ``tests/track/batch`` and
``scripts/bench_tma.py`` hold plain numpy implementations of the same sums; the kernels agree
with them to rounding.

Written by hand (no maintained library does it): :func:`atan2` is a branch-free arc tangent
(octant reduction, then the tangent-addition reduction to ``|u| ≤ tan(π/12)`` and a
near-minimax polynomial of degree 17 in u: 9 coefficients where the Taylor series of the
same accuracy needs 14). numba lowers
``np.arctan2`` to a scalar libm call (36 ns per call measured on this machine, 2026-12-01);
this version is plain arithmetic that LLVM can vectorise, and agrees with ``np.arctan2`` to a
few ulp (tested). The exponential (Ornstein-Uhlenbeck) correlation of the compact-array
bearing errors is Markov, so ``eᵀC⁻¹e`` is a sum of squared innovations
``(e_b − φ_b e_{b−1}) / (σ √(1 − φ_b²))`` with ``φ_b = exp(−(t_b − t_{b−1})/τ)`` (exact for
increasing times): :func:`compact_grid_cost` uses this O(N) form; ``φ = 0`` is the diagonal C.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from .motion import N_RETARD

_PI = np.pi
_HALF_PI = 0.5 * np.pi
_SIXTH_PI = np.pi / 6.0
_TAN_12 = 0.2679491924311227  # tan(π/12)
_INV_SQRT3 = 0.5773502691896258  # tan(π/6)
_TWO_PI = 2.0 * np.pi


@njit(cache=True, inline="always", fastmath=True, error_model="numpy")
def atan2(y: float, x: float) -> float:
    """Four-quadrant arc tangent of y/x (rad), as ``np.arctan2(y, x)`` (to a few ulp for
    normal floats; subnormal inputs lose precision)."""
    ax = abs(x)
    ay = abs(y)
    mx = max(ax, ay)
    mn = min(ax, ay)
    big = mn > _TAN_12 * mx
    # u = t or (t − 1/√3)/(1 + t/√3) with t = mn/mx, as one division
    num = mn - _INV_SQRT3 * mx if big else mn
    den = mx + _INV_SQRT3 * mn if big else mx
    u = num / den if den > 0.0 else 0.0
    base = _SIXTH_PI if big else 0.0
    z = u * u
    # atan(u) = u + u z h(z), h the near-minimax polynomial of degree 7 in z = u² on
    # [0, tan²(π/12)] (Chebyshev interpolation in extended precision; relative error of
    # atan below 2.7e-16, i.e. under one ulp, measured on 2e5 points)
    p = 0.045798311833685705
    p = p * z - 0.06522374321053691
    p = p * z + 0.07683767862541686
    p = p * z - 0.09090626202302309
    p = p * z + 0.11111105996992846
    p = p * z - 0.14285714240198755
    p = p * z + 0.19999999999845575
    p = p * z - 0.3333333333333325
    a = base + (u + u * z * p)
    a = _HALF_PI - a if ay > ax else a
    a = _PI - a if x < 0.0 else a
    return -a if y < 0.0 else a


@njit(cache=True, inline="always", fastmath=True, error_model="numpy")
def wrap_pi(a: float) -> float:
    """Angle wrapped to [−π, π) (rad)."""
    return a - _TWO_PI * np.floor((a + _PI) / _TWO_PI)


@njit(cache=True, fastmath=True, error_model="numpy")
def atan2_array(y: np.ndarray, x: np.ndarray) -> np.ndarray:
    """:func:`atan2` element-wise over 1-D arrays (for tests)."""
    out = np.empty(y.size)
    for i in range(y.size):
        out[i] = atan2(y[i], x[i])
    return out


@njit(cache=True, parallel=True, fastmath=True, error_model="numpy")
def bo_cost_population(pop: np.ndarray, tau: np.ndarray, obs: np.ndarray, meas: np.ndarray,
                       weight: np.ndarray, inv_c: float = 0.0) -> np.ndarray:
    """Bearings-only cost Σ_b (w_b · wrap(θ_b − h_b(x)))² for each state of a population.

    thesis eqs. (3.44), (3.47). ``pop`` (4, P) states [x, y, vx, vy] at the window start (m,
    m/s), as scipy's vectorised ``differential_evolution`` passes them; ``tau`` (B,) s since
    the window start; ``obs`` (B, 2) observer position (m); ``meas`` (B,) bearings (rad,
    clockwise from north); ``weight`` (B,) 1/σ_b (1/rad); ``inv_c`` 1/c (s/m) to take the
    source at its emission time (eq. (M5) of :mod:`.motion`, ``N_RETARD`` fixed-point
    steps), 0 for the thesis's model. Returns (P,).
    """
    n_pop = pop.shape[1]
    out = np.empty(n_pop)
    for p in prange(n_pop):
        s = 0.0
        for b in range(tau.size):
            dx, dy = _source_offset(pop[0, p], pop[1, p], pop[2, p], pop[3, p], tau[b],
                                    obs[b, 0], obs[b, 1], inv_c)
            r = wrap_pi(meas[b] - atan2(dx, dy)) * weight[b]
            s += r * r
        out[p] = s
    return out


@njit(cache=True, inline="always", fastmath=True, error_model="numpy")
def _source_offset(x0: float, y0: float, vx: float, vy: float, tau: float, ox: float,
                   oy: float, inv_c: float) -> tuple[float, float]:
    """Source minus observer (m) at ``tau`` s into the window, the source at constant velocity
    (eq. (3.41)) and, with ``inv_c`` > 0, at its emission time (eq. (M5), ``N_RETARD``
    fixed-point steps)."""
    dx = x0 + vx * tau - ox
    dy = y0 + vy * tau - oy
    if inv_c > 0.0:
        ax = dx
        ay = dy
        for _ in range(N_RETARD):
            dt = np.sqrt(dx * dx + dy * dy) * inv_c
            dx = ax - vx * dt
            dy = ay - vy * dt
    return dx, dy


@njit(cache=True, parallel=True, fastmath=True, error_model="numpy")
def cone_cost_population(pop: np.ndarray, tau: np.ndarray, obs: np.ndarray, cone: np.ndarray,
                         heading: np.ndarray, weight: np.ndarray, inv_c: float = 0.0
                         ) -> np.ndarray:
    """Line-array cost Σ_b (w_b (θ_b − |wrap(h_b(x) − ψ_b)|))² for each state of a population.

    The cone angle of the bearing ``h_b(x)`` of eq. (3.44) on an array of heading ``ψ_b``
    (rad): no mirror side is chosen, so the source may cross end-fire or change side within
    the window. ``cone`` (B,) measured cone angles (rad, 0 forward end-fire); the other
    arguments as :func:`bo_cost_population`. Returns (P,).
    """
    n_pop = pop.shape[1]
    out = np.empty(n_pop)
    for p in prange(n_pop):
        s = 0.0
        for b in range(tau.size):
            dx, dy = _source_offset(pop[0, p], pop[1, p], pop[2, p], pop[3, p], tau[b],
                                    obs[b, 0], obs[b, 1], inv_c)
            r = (cone[b] - abs(wrap_pi(atan2(dx, dy) - heading[b]))) * weight[b]
            s += r * r
        out[p] = s
    return out


@njit(cache=True, parallel=True, fastmath=True, error_model="numpy")
def td_cost_population(pop: np.ndarray, tau: np.ndarray, elem_x: np.ndarray,
                       elem_y: np.ndarray, dz2: np.ndarray, wmeas: np.ndarray,
                       w_over_c: np.ndarray, ref: int, inv_c: float = 0.0) -> np.ndarray:
    """Time-delay TMA cost Σ_{b,n} (w_bn (τ_bn − h_bn(x)))² for each state of a population.

    thesis eqs. (3.51), (3.52): ``h_bn = (r_bn − r_b,ref) / c`` with
    ``r_bn = √(|p_b − e_bn|² + Δz_bn²)`` and ``p_b = (x + vx t_b, y + vy t_b)``, or with
    ``inv_c = 1/c > 0`` the emission point of eq. (M5) (:mod:`.motion`; receiver the
    reference element, ``N_RETARD`` fixed-point steps). ``pop`` (4, P); ``tau`` (B,) s since
    the window start; ``elem_x``, ``elem_y`` (B, N) element positions (m, world; contiguous
    rows, so that the inner loop over hydrophones vectorises); ``dz2`` (B, N) squared depth
    differences element − source (m², zeros for the planar model); ``wmeas`` (B, N) = w τ
    with ``w = 1/σ`` (0 for unused entries, e.g. the reference); ``w_over_c`` (B, N) = w / c.
    Returns (P,).
    """
    n_pop = pop.shape[1]
    n_b, n_h = wmeas.shape
    out = np.empty(n_pop)
    for p in prange(n_pop):
        s = 0.0
        vx = pop[2, p]
        vy = pop[3, p]
        for b in range(n_b):
            px = pop[0, p] + vx * tau[b]
            py = pop[1, p] + vy * tau[b]
            rx = px - elem_x[b, ref]
            ry = py - elem_y[b, ref]
            if inv_c > 0.0:
                ax = px
                ay = py
                for _ in range(N_RETARD):
                    dt = np.sqrt(rx * rx + ry * ry + dz2[b, ref]) * inv_c
                    px = ax - vx * dt
                    py = ay - vy * dt
                    rx = px - elem_x[b, ref]
                    ry = py - elem_y[b, ref]
            r_ref = np.sqrt(rx * rx + ry * ry + dz2[b, ref])
            for n in range(n_h):
                dx = px - elem_x[b, n]
                dy = py - elem_y[b, n]
                e = wmeas[b, n] - w_over_c[b, n] * (np.sqrt(dx * dx + dy * dy + dz2[b, n])
                                                    - r_ref)
                s += e * e
        out[p] = s
    return out


@njit(cache=True, parallel=True, fastmath=True, error_model="numpy")
def compact_grid_cost(xs: np.ndarray, ys: np.ndarray, headings: np.ndarray, speed: float,
                      tau: np.ndarray, array_xy: np.ndarray, meas: np.ndarray, phi: np.ndarray,
                      scale: np.ndarray) -> np.ndarray:
    """Compact-array cost ``eᵀC⁻¹e`` on a grid of (x0, y0, heading) (compact-array paper eq. (4)).

    The source moves from (x0, y0) at ``speed`` along ``heading`` (rad, clockwise from north;
    paper eq. (1)); ``e_b = wrap(α̂_b − α_b)``; C is the exponential (or, with ``phi = 0``,
    diagonal) covariance in innovation form: ``eᵀC⁻¹e = Σ_b (scale_b (e_b − φ_b e_{b−1}))²``.
    ``xs`` (I,), ``ys`` (J,) m; ``headings`` (K,) rad; ``tau`` (B,) s since the window start;
    ``array_xy`` (2,) m; ``meas`` (B,) rad; ``phi``, ``scale`` (B,) (``phi[0] = 0``).
    Returns (I, J, K).
    """
    n_i, n_j, n_k = xs.size, ys.size, headings.size
    n_b = tau.size
    out = np.empty((n_i, n_j, n_k))
    sx = np.empty((n_k, n_b))
    sy = np.empty((n_k, n_b))
    for k in range(n_k):
        for b in range(n_b):
            sx[k, b] = speed * np.sin(headings[k]) * tau[b] - array_xy[0]
            sy[k, b] = speed * np.cos(headings[k]) * tau[b] - array_xy[1]
    sm = np.sin(meas)
    cm = np.cos(meas)
    for i in prange(n_i):
        acc = np.empty(n_j)
        prev = np.empty(n_j)
        for k in range(n_k):
            acc[:] = 0.0
            prev[:] = 0.0
            for b in range(n_b):
                ox = xs[i] + sx[k, b]
                oy = sy[k, b]
                s_b = sm[b]
                c_b = cm[b]
                ph = phi[b]
                sc = scale[b]
                # innermost over y: independent lanes (vectorised). The residual
                # wrap(α̂ − α) is the angle from the predicted direction d to the measured
                # one u: −atan2(d × u, d · u), already in (−π, π].
                for j in range(n_j):
                    dy = ys[j] + oy
                    e = -atan2(ox * c_b - dy * s_b, ox * s_b + dy * c_b)
                    w = (e - ph * prev[j]) * sc
                    acc[j] += w * w
                    prev[j] = e
            for j in range(n_j):
                out[i, j, k] = acc[j]
    return out


@njit(cache=True, parallel=True, fastmath=True, error_model="numpy")
def td_model_jacobian(state: np.ndarray, tau: np.ndarray, elem_x: np.ndarray,
                      elem_y: np.ndarray, dz2: np.ndarray, ref: int, sound_speed: float,
                      retarded: bool) -> tuple[np.ndarray, np.ndarray]:
    """Delays ``h_bn(x)`` (thesis eq. (3.51)) and their Jacobian (eqs. (C.13)-(C.15)) at one
    state, in one pass (the least-squares polish and the FIM of time-delay TMA).

    ``state`` (4,) [x, y, vx, vy] at the window start; ``tau`` (B,) s; ``elem_x``, ``elem_y``
    (B, N) element positions (m); ``dz2`` (B, N) squared depth differences (m², zeros for
    the planar model); ``ref`` the reference element; ``retarded``: the source at its
    emission time (eq. (M5) of :mod:`.motion`, ``N_RETARD`` fixed-point steps, exact
    derivative ``M⁻¹ [I, τ_e I]``, ``M⁻¹ = I − v ûᵀ/(c + û·v)``). Returns ``h`` (B, N) s and
    ``∂h/∂x`` (B, N, 4); the numpy twins are ``td_tma.delay_model`` and
    ``fim.td_jacobian``.
    """
    n_b, n_h = elem_x.shape
    h = np.empty((n_b, n_h))
    jac = np.empty((n_b, n_h, 4))
    x0, y0, vx, vy = state[0], state[1], state[2], state[3]
    c = sound_speed
    for b in prange(n_b):
        tb = tau[b]
        px = x0 + vx * tb
        py = y0 + vy * tb
        rx = px - elem_x[b, ref]
        ry = py - elem_y[b, ref]
        if retarded:
            for _ in range(N_RETARD):
                tb = tau[b] - np.sqrt(rx * rx + ry * ry + dz2[b, ref]) / c
                px = x0 + vx * tb
                py = y0 + vy * tb
                rx = px - elem_x[b, ref]
                ry = py - elem_y[b, ref]
        r_ref = np.sqrt(rx * rx + ry * ry + dz2[b, ref])
        ux = rx / r_ref
        uy = ry / r_ref
        m00, m01, m10, m11 = 1.0, 0.0, 0.0, 1.0
        if retarded:
            den = c + ux * vx + uy * vy
            m00 = 1.0 - vx * ux / den
            m01 = -vx * uy / den
            m10 = -vy * ux / den
            m11 = 1.0 - vy * uy / den
        for n in range(n_h):
            dx = px - elem_x[b, n]
            dy = py - elem_y[b, n]
            r = np.sqrt(dx * dx + dy * dy + dz2[b, n])
            h[b, n] = (r - r_ref) / c
            gx = (dx / r - ux) / c
            gy = (dy / r - uy) / c
            jx = gx * m00 + gy * m10
            jy = gx * m01 + gy * m11
            jac[b, n, 0] = jx
            jac[b, n, 1] = jy
            jac[b, n, 2] = tb * jx
            jac[b, n, 3] = tb * jy
    return h, jac


@njit(cache=True, parallel=True, fastmath=True, error_model="numpy")
def bf_cost_population(pop: np.ndarray, tau: np.ndarray, obs: np.ndarray, obs_vel: np.ndarray,
                       angle: np.ndarray, heading: np.ndarray, cone_mode: bool,
                       w_angle: np.ndarray, freq: np.ndarray, w_freq: np.ndarray,
                       inv_c: float) -> np.ndarray:
    """Bearings + frequency cost for each state of a population, the rest frequency profiled.

    Angle terms as :func:`bo_cost_population` (``cone_mode`` False: bearings ``angle``) or
    :func:`cone_cost_population` (True: cone angles on headings ``heading``). Frequency terms
    ``Σ_b (w_b (f_b − f0 g_b(x)))²`` with the Doppler factor ``g_b = 1 − ṙ_b / c`` (``ṙ`` the
    range rate, opening positive, from the source's and the observer's velocities
    ``obs_vel`` (B, 2) m/s) and, for each state, the least-squares rest frequency
    ``f0 = Σ w² g f / Σ w² g²`` (the cost is quadratic in ``f0``). Returns (P,).
    """
    n_pop = pop.shape[1]
    out = np.empty(n_pop)
    for p in prange(n_pop):
        vx = pop[2, p]
        vy = pop[3, p]
        s = 0.0
        sgg = 0.0
        sgf = 0.0
        sff = 0.0
        for b in range(tau.size):
            dx, dy = _source_offset(pop[0, p], pop[1, p], vx, vy, tau[b], obs[b, 0],
                                    obs[b, 1], 0.0)
            brg = atan2(dx, dy)
            if cone_mode:
                r = (angle[b] - abs(wrap_pi(brg - heading[b]))) * w_angle[b]
            else:
                r = wrap_pi(angle[b] - brg) * w_angle[b]
            s += r * r
            rng = np.sqrt(dx * dx + dy * dy)
            rdot = (dx * (vx - obs_vel[b, 0]) + dy * (vy - obs_vel[b, 1])) / rng
            g = 1.0 - rdot * inv_c
            w2 = w_freq[b] * w_freq[b]
            sgg += w2 * g * g
            sgf += w2 * g * freq[b]
            sff += w2 * freq[b] * freq[b]
        out[p] = s + sff - sgf * sgf / sgg
    return out
