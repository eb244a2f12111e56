"""Retarded-time propagation kernels of the simulator (one-way and two-way), numba.

One-way (``oneway_accumulate``): for every output sample k (time t_k) and element n, the
element's world position x_n(t_k) is built exactly from the array pose at t_k, and the travel
time τ solves the retarded-time equation

    c·τ = | x_n(t_k) − x_s(t_k − τ) |

(thesis eq. (2.47) without its far-field approximation). The source position near the
retarded time is a second-order Taylor expansion about t_k − τ_ref, τ_ref close to the
reference point's retarded time (exact position, velocity and acceleration supplied by the
caller), valid because |τ − τ_ref| ≤ aperture/c; the neglected third-order term is below
1e-9 m for ship motion. τ is found by one fixed-point step and one Newton step (quadratic
convergence; residual ≤ 3e-11 s at 10 m range and 20 m/s, ~1e-12 s beyond 100 m).
The received pressure is ``g(cτ) · s(t_k − τ)``, with ``s`` read by the windowed-sinc
fractional-delay interpolator, so Doppler and wavefront curvature come from the geometry.

Two-way (``echo_accumulate``): a pulse emitted at t_e from a moving projector, scattered at
t_s by a moving point target and received at t_k by element n satisfies

    c·(t_k − t_s) = | x_n(t_k) − x_T(t_s) |,   c·(t_s − t_e) = | x_T(t_s) − x_P(t_e) |,

solved the same way (target Taylor-expanded about the reference point's t_s, projector about
its t_e). For a static monostatic sonar and a target at constant range rate ṙ this gives the
exact time scaling d = (c − ṙ)/(c + ṙ) of thesis eq. (4.8). An optional time distortion
t ↦ t + α sin(2πt/T)(1 − cos 2πt/T) of the pulse (thesis eq. (4.6)) adds Doppler spread.

Image sources (``arrayproc.sim.multipath``): the caller passes an image's states (depth
mirrored) and its reflection coefficient as ``scale``; the kernels add the rough surface's
per-element coherent factor.

Loss laws (``amp_mode``): 0 spherical 1/r; 1 cylindrical beyond a transition range r_t
(1/r up to r_t, then 1/√(r_t·r)); 2 tabulated amplitude gain on a uniform range grid, read
linearly.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from arrayproc.dsp.fracdelay import interp_one

NEWTON_STEPS = 1


@njit(cache=True, inline="always")
def _gain(r: float, amp_mode: int, r_t: float, gtab: np.ndarray, g_r0: float,
          g_dr: float) -> float:
    if r < 1.0:
        r = 1.0
    if amp_mode == 0:
        return 1.0 / r
    if amp_mode == 1:
        if r <= r_t:
            return 1.0 / r
        return 1.0 / math.sqrt(r_t * r)
    x = (r - g_r0) / g_dr
    if x <= 0.0:
        return gtab[0]
    i = int(x)
    if i >= gtab.shape[0] - 1:
        return gtab[gtab.shape[0] - 1]
    f = x - i
    return gtab[i] + f * (gtab[i + 1] - gtab[i])


@njit(cache=True, inline="always")
def _element(k: int, ch: int, epos: np.ndarray, rpos: np.ndarray, rdepth: np.ndarray,
             sin_h: np.ndarray, cos_h: np.ndarray, lateral: np.ndarray,
             body: np.ndarray) -> tuple[float, float, float]:
    """World position of element ch at sample k: from ``epos`` (a bending array) when it has
    rows, else the rigid pose (body position rotated by the heading, lateral offset added)."""
    if epos.shape[0] > 0:
        return epos[k, ch, 0], epos[k, ch, 1], epos[k, ch, 2]
    by = body[ch, 1] + lateral[k]
    return (rpos[k, 0] + body[ch, 0] * sin_h[k] + by * cos_h[k],
            rpos[k, 1] + body[ch, 0] * cos_h[k] - by * sin_h[k], rdepth[k] + body[ch, 2])


@njit(cache=True, inline="always")
def _rough(rough: float, dz: float, dist: float) -> float:
    """exp(−rough·sin²θ), sin θ = |dz|/dist: the coherent reflection of a rough surface."""
    s = dz / max(dist, 1e-6)
    return math.exp(-rough * s * s)


@njit(cache=True, inline="always", fastmath=True)
def _solve(ex: float, ey: float, ez: float, tau0: float, p: np.ndarray, v: np.ndarray,
           a: np.ndarray, k: int, c: float) -> float:
    """τ with c·τ = |e − x_s(t − τ)|, x_s Taylor-expanded about t − tau0 (row k of p, v, a).

    One fixed-point step from the expansion point (error ≤ (|v|/c)·|τ − tau0|, < 1e-4 s)
    then one Newton step, which squares the relative error. Measured against the converged
    root (element 12 m off the expansion point, |v| = 20 m/s, |a| ~ 0.5 m/s²): 3e-11 s at
    10 m range, 3e-12 s at 100 m, about 1e-12 s (rounding) at 1-10 km.
    """
    px = p[k, 0]
    py = p[k, 1]
    pz = p[k, 2]
    dx = ex - px
    dy = ey - py
    dz = ez - pz
    tau = math.sqrt(dx * dx + dy * dy + dz * dz) / c
    for _ in range(NEWTON_STEPS):
        d = tau - tau0
        hd = 0.5 * d * d
        sx = px - v[k, 0] * d + a[k, 0] * hd
        sy = py - v[k, 1] * d + a[k, 1] * hd
        sz = pz - v[k, 2] * d + a[k, 2] * hd
        wx = v[k, 0] - a[k, 0] * d
        wy = v[k, 1] - a[k, 1] * d
        wz = v[k, 2] - a[k, 2] * d
        dx = ex - sx
        dy = ey - sy
        dz = ez - sz
        dist = max(math.sqrt(dx * dx + dy * dy + dz * dz), 1e-6)
        f = c * tau - dist
        fp = c - (dx * wx + dy * wy + dz * wz) / dist
        tau -= f / fp
    return tau


BLOCK = 128  # samples per parallel work item


@njit(cache=True, parallel=True, fastmath=True)
def oneway_accumulate(out: np.ndarray, ref_tau: np.ndarray, spos: np.ndarray,
                      svel: np.ndarray, sacc: np.ndarray, t: np.ndarray, rpos: np.ndarray,
                      rdepth: np.ndarray, sin_h: np.ndarray, cos_h: np.ndarray,
                      lateral: np.ndarray, body: np.ndarray, c: float, sig: np.ndarray,
                      sig_t0: float, fs_src: float, table: np.ndarray, amp_mode: int,
                      r_t: float, gtab: np.ndarray, g_r0: float, g_dr: float,
                      scale: float, wamp: np.ndarray, epos: np.ndarray,
                      rough: float) -> None:
    """Add one source's (or one image path's) field to ``out`` (n, ch) float32.

    Per sample k: ``t[k]`` reception time (s); ``rpos[k]`` array reference point (x, y) and
    ``rdepth[k]`` its depth (m); ``sin_h``/``cos_h`` of the heading; ``lateral[k]`` lateral
    (starboard) offset of every element (m). ``body`` (ch, 3) element positions in the body
    frame. ``ref_tau[k]`` a travel time close to the reference point's (the expansion point)
    and ``spos/svel/sacc`` (n, 3) the source's exact state at ``t[k] − ref_tau[k]``. ``sig``
    is the source signal at rate ``fs_src`` whose sample 0 is at emission time ``sig_t0``;
    ``scale`` multiplies the result and ``wamp[k]`` the sample's (a path's reflection factor).
    ``epos`` (n, ch, 3): element world positions per sample (a bending array); with zero rows
    the rigid pose above is used. ``rough`` = n_surface·2(kσ)²: the rough surface's coherent
    factor exp(−rough·sin²θ), θ the grazing angle of the path to each element (0: smooth).
    Parallel over blocks of samples; the result of a sample does not depend on the blocking.
    """
    n = out.shape[0]
    nch = out.shape[1]
    half = table.shape[1] // 2
    ns = sig.shape[0]
    nblk = (n + BLOCK - 1) // BLOCK
    for b in prange(nblk):
        tau = np.empty(nch)
        zel = np.empty(nch)
        for k in range(b * BLOCK, min(n, (b + 1) * BLOCK)):
            t0 = ref_tau[k]
            for ch in range(nch):
                ex, ey, ez = _element(k, ch, epos, rpos, rdepth, sin_h, cos_h, lateral, body)
                tau[ch] = _solve(ex, ey, ez, t0, spos, svel, sacc, k, c)
                zel[ch] = ez
            tk = t[k]
            sk = scale * wamp[k]
            for ch in range(nch):
                u = (tk - tau[ch] - sig_t0) * fs_src
                if u < half - 1 or u >= ns - half - 1:
                    continue
                g = _gain(c * tau[ch], amp_mode, r_t, gtab, g_r0, g_dr)
                if rough != 0.0:
                    g *= _rough(rough, spos[k, 2] - zel[ch], c * tau[ch])
                out[k, ch] += sk * g * interp_one(sig, u, table)


@njit(cache=True, parallel=True, fastmath=True)
def echo_accumulate(out: np.ndarray, k0: int, ts_ref: np.ndarray, tpos: np.ndarray,
                    tvel: np.ndarray, tacc: np.ndarray, te_ref: np.ndarray, ppos: np.ndarray,
                    pvel: np.ndarray, pacc: np.ndarray, t: np.ndarray, rpos: np.ndarray,
                    rdepth: np.ndarray, sin_h: np.ndarray, cos_h: np.ndarray,
                    lateral: np.ndarray, body: np.ndarray, c: float, sig: np.ndarray,
                    t_ping: float, sig_t0: float, fs_src: float, table: np.ndarray,
                    amp_mode: int, r_t: float, gtab: np.ndarray, g_r0: float, g_dr: float,
                    scale: float, alpha: float, pulse_len: float, wamp: np.ndarray,
                    epos: np.ndarray, za: float, zs: float, rough_r: float,
                    rough_t: float) -> None:
    """Add one echo (one ping, one scatterer) to ``out[k0 : k0 + len(t)]`` (float32).

    Arrays indexed by k are over the echo window's samples ``t[k]``. ``ts_ref/te_ref`` are the
    reference point's exact scattering and emission times, with the target's and the
    projector's exact states at them (n, 3). ``sig`` is the pulse sampled at ``fs_src``, its
    sample 0 at pulse time ``sig_t0`` (s after the ping's start ``t_ping``); ``alpha`` (s) is
    the eq. (4.6) distortion amplitude over the pulse length ``pulse_len`` (s). ``wamp[k]``
    multiplies sample k and ``epos`` (n or 0, ch, 3) are bent-array element positions, as in
    :func:`oneway_accumulate`. Image paths: the target states are those of the receive leg's
    image (depth z' = a + s·z) and ``za + zs·z'`` maps the image depth back to the target's
    (identity: 0, 1); the projector states are the transmit leg's image. ``rough_r`` and
    ``rough_t``: each leg's rough-surface exponent, as ``rough`` of :func:`oneway_accumulate`.
    """
    n = t.shape[0]
    nch = out.shape[1]
    half = table.shape[1] // 2
    ns = sig.shape[0]
    two_pi = 2.0 * math.pi
    nblk = (n + BLOCK - 1) // BLOCK
    for b in prange(nblk):
        for k in range(b * BLOCK, min(n, (b + 1) * BLOCK)):
            tk = t[k]
            tau0 = tk - ts_ref[k]
            for ch in range(nch):
                ex, ey, ez = _element(k, ch, epos, rpos, rdepth, sin_h, cos_h, lateral, body)
                # receive leg: c·τ2 = |e − x_T(t − τ2)|, t_s = t − τ2
                tau2 = _solve(ex, ey, ez, tau0, tpos, tvel, tacc, k, c)
                ts = tk - tau2
                d2 = ts - ts_ref[k]
                hd = 0.5 * d2 * d2
                tx = tpos[k, 0] + tvel[k, 0] * d2 + tacc[k, 0] * hd
                ty = tpos[k, 1] + tvel[k, 1] * d2 + tacc[k, 1] * hd
                tz = za + zs * (tpos[k, 2] + tvel[k, 2] * d2 + tacc[k, 2] * hd)
                # transmit leg: c·τ1 = |x_T(t_s) − x_P(t_s − τ1)|, t_e = t_s − τ1
                tau1 = _solve(tx, ty, tz, ts - te_ref[k], ppos, pvel, pacc, k, c)
                tp = ts - tau1 - t_ping  # pulse time of the emission
                if alpha != 0.0:  # thesis eq. (4.6)
                    s = two_pi * tp / pulse_len
                    tp = tp + alpha * math.sin(s) * (1.0 - math.cos(s))
                u = (tp - sig_t0) * fs_src
                if u < half - 1 or u >= ns - half - 1:
                    continue
                g = (_gain(c * tau2, amp_mode, r_t, gtab, g_r0, g_dr)
                     * _gain(c * tau1, amp_mode, r_t, gtab, g_r0, g_dr))
                if rough_r != 0.0:
                    g *= _rough(rough_r, tpos[k, 2] - ez, c * tau2)
                if rough_t != 0.0:
                    g *= _rough(rough_t, ppos[k, 2] - tz, c * tau1)
                out[k0 + k, ch] += scale * wamp[k] * g * interp_one(sig, u, table)


#: The same echo kernel compiled serially: for short windows (reverberation scatterers, a few
#: hundred samples on few channels) the parallel launch costs more than the work.
echo_accumulate_serial = njit(cache=True, fastmath=True)(echo_accumulate.py_func)


@njit(cache=True, inline="always")
def _tab_lin(tab: np.ndarray, col: int, x: float) -> float:
    if x <= 0.0:
        return tab[0, col]
    i = int(x)
    if i >= tab.shape[0] - 1:
        return tab[tab.shape[0] - 1, col]
    f = x - i
    return tab[i, col] + f * (tab[i + 1, col] - tab[i, col])


@njit(cache=True, parallel=True, fastmath=True)
def table_accumulate(out: np.ndarray, ref_tau: np.ndarray, spos: np.ndarray, svel: np.ndarray,
                     sacc: np.ndarray, t: np.ndarray, rpos: np.ndarray, rdepth: np.ndarray,
                     sin_h: np.ndarray, cos_h: np.ndarray, lateral: np.ndarray,
                     body: np.ndarray, epos: np.ndarray, sig: np.ndarray, sigq: np.ndarray,
                     sig_t0: float, fs_src: float, table: np.ndarray, tab: np.ndarray,
                     r0: float, dr: float, scale: float) -> None:
    """Add one tabulated ray family (BELLHOP arrivals) of one source to ``out`` (n, ch).

    ``tab`` (n_r, 3): the family's delay τ(r) (s) and complex amplitude A(r)·e^{iφ(r)} (real,
    imaginary) on horizontal ranges r0 + i·dr. Per sample and element the travel time solves
    τ = τ_fam(r_h(t − τ)), r_h the horizontal distance from the element to the source at
    emission (Taylor-expanded about t − ref_tau as in :func:`oneway_accumulate`), by three
    fixed-point steps (contraction |v_S|/c); the pressure is
    Re A·s(t − τ) − Im A·ŝ(t − τ), ŝ = ``sigq`` the source signal's Hilbert transform: a tonal
    cos ωt arrives as |A| cos(ω(t − τ) + φ), whose phasor Σ A e^{i(φ − ωτ)} is BELLHOP's
    coherent pressure. Other arguments as in :func:`oneway_accumulate`.
    """
    n = out.shape[0]
    nch = out.shape[1]
    half = table.shape[1] // 2
    ns = sig.shape[0]
    nblk = (n + BLOCK - 1) // BLOCK
    for b in prange(nblk):
        for k in range(b * BLOCK, min(n, (b + 1) * BLOCK)):
            t0 = ref_tau[k]
            for ch in range(nch):
                ex, ey, _ = _element(k, ch, epos, rpos, rdepth, sin_h, cos_h, lateral, body)
                tau = t0
                x = 0.0
                for _ in range(3):
                    d = tau - t0
                    hd = 0.5 * d * d
                    sx = spos[k, 0] - svel[k, 0] * d + sacc[k, 0] * hd
                    sy = spos[k, 1] - svel[k, 1] * d + sacc[k, 1] * hd
                    rh = math.sqrt((ex - sx) ** 2 + (ey - sy) ** 2)
                    x = (rh - r0) / dr
                    tau = _tab_lin(tab, 0, x)
                u = (t[k] - tau - sig_t0) * fs_src
                if u < half - 1 or u >= ns - half - 1:
                    continue
                are = _tab_lin(tab, 1, x)
                aim = _tab_lin(tab, 2, x)
                out[k, ch] += scale * (are * interp_one(sig, u, table)
                                       - aim * interp_one(sigq, u, table))
