"""Two-way kernel of tabulated ray families (BELLHOP arrivals) for active echoes, numba.

An echo path is a pair of ray families: transmit family i (projector → scatterer) and receive
family j (scatterer → element). Per output sample k (time t_k) and element n the receive leg
solves τ₂ = τ_j(r_h(x_n(t_k), x_T(t_k − τ₂))) and the transmit leg, from the scattering time
t_s = t_k − τ₂, solves τ₁ = τ_i(r_h(x_T(t_s), x_P(t_s − τ₁))), r_h horizontal distances and
τ_j, τ_i the families' delays, linear in range (the one-way
:func:`arrayproc.sim._propagate_kernels.table_accumulate` applied twice). The echo is

    Re(A_i A_j)·s(t_p) − Im(A_i A_j)·ŝ(t_p),   t_p = t_k − τ₂ − τ₁ − t_ping,

A_i, A_j the families' complex amplitudes at their ranges (phases added) and ŝ the pulse's
Hilbert transform, so a tonal component cos ωt arrives as |A_i A_j| cos(ω(t − τ₁ − τ₂) + φ_i +
φ_j): every pair of eigenrays is one echo path with delay τ₁ + τ₂ and amplitude A₁A₂, as the
image-source pairs of :func:`arrayproc.sim._propagate_kernels.echo_accumulate`. The target and
the projector are Taylor-expanded about per-sample reference times, as there.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from arrayproc.dsp.fracdelay import interp_one
from arrayproc.sim._propagate_kernels import BLOCK, _element, _tab_lin

FIXED_POINT_STEPS = 4  # contraction |v|/c < 0.01 per step, from an error ≤ the delay spread


@njit(cache=True, inline="always")
def _leg(tab: np.ndarray, ex: float, ey: float, tau0: float, p: np.ndarray, v: np.ndarray,
         a: np.ndarray, k: int, r0: float, dr: float) -> tuple[float, float]:
    """(τ, x): τ = τ_fam(r_h(e, x_S(t − τ))), x_S Taylor-expanded about t − tau0 (row k of
    p, v, a), and x the range grid coordinate where the family is read."""
    tau = tau0
    x = 0.0
    for _ in range(FIXED_POINT_STEPS):
        d = tau - tau0
        hd = 0.5 * d * d
        sx = p[k, 0] - v[k, 0] * d + a[k, 0] * hd
        sy = p[k, 1] - v[k, 1] * d + a[k, 1] * hd
        x = (math.sqrt((ex - sx) ** 2 + (ey - sy) ** 2) - r0) / dr
        tau = _tab_lin(tab, 0, x)
    return tau, x


@njit(cache=True, parallel=True, fastmath=True)
def echo_table_accumulate(out: np.ndarray, k0: int, ts_ref: np.ndarray, tpos: np.ndarray,
                          tvel: np.ndarray, tacc: np.ndarray, te_ref: np.ndarray,
                          ppos: np.ndarray, pvel: np.ndarray, pacc: np.ndarray, t: np.ndarray,
                          rpos: np.ndarray, rdepth: np.ndarray, sin_h: np.ndarray,
                          cos_h: np.ndarray, lateral: np.ndarray, body: np.ndarray,
                          epos: np.ndarray, sig: np.ndarray, sigq: np.ndarray, t_ping: float,
                          sig_t0: float, fs_src: float, table: np.ndarray, tab_r: np.ndarray,
                          tab_t: np.ndarray, r0: float, dr: float, scale: float, alpha: float,
                          pulse_len: float) -> None:
    """Add one echo (one ping, one scatterer) over every transmit × receive family pair to
    ``out[k0 : k0 + len(t)]`` (float32).

    ``tab_r`` (n_j, n_r, 3) and ``tab_t`` (n_i, n_r, 3): the receive and transmit families'
    delay (s) and complex amplitude (real, imaginary) on horizontal ranges r0 + m·dr.
    ``ts_ref``/``te_ref`` per sample: the reference scattering and emission times, with the
    target's (``tpos``, ``tvel``, ``tacc``) and the projector's (``ppos``, …) exact states at
    them. ``sig``/``sigq``: the pulse and its Hilbert transform at ``fs_src``, sample 0 at
    pulse time ``sig_t0``; ``alpha`` the thesis eq. (4.6) distortion over ``pulse_len``. Pose
    arguments as in :func:`arrayproc.sim._propagate_kernels.echo_accumulate`.
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
            for ch in range(nch):
                ex, ey, _ = _element(k, ch, epos, rpos, rdepth, sin_h, cos_h, lateral, body)
                acc = 0.0
                for j in range(tab_r.shape[0]):
                    tr = tab_r[j]
                    tau2, xr = _leg(tr, ex, ey, tk - ts_ref[k], tpos, tvel, tacc, k, r0, dr)
                    ar = _tab_lin(tr, 1, xr)
                    ai = _tab_lin(tr, 2, xr)
                    if ar == 0.0 and ai == 0.0:
                        continue
                    ts = tk - tau2
                    d2 = ts - ts_ref[k]
                    hd = 0.5 * d2 * d2
                    tx = tpos[k, 0] + tvel[k, 0] * d2 + tacc[k, 0] * hd
                    ty = tpos[k, 1] + tvel[k, 1] * d2 + tacc[k, 1] * hd
                    for i in range(tab_t.shape[0]):
                        tt = tab_t[i]
                        tau1, xt = _leg(tt, tx, ty, ts - te_ref[k], ppos, pvel, pacc, k,
                                        r0, dr)
                        tp = ts - tau1 - t_ping
                        if alpha != 0.0:  # thesis eq. (4.6)
                            s = two_pi * tp / pulse_len
                            tp = tp + alpha * math.sin(s) * (1.0 - math.cos(s))
                        u = (tp - sig_t0) * fs_src
                        if u < half - 1 or u >= ns - half - 1:
                            continue
                        br = _tab_lin(tt, 1, xt)
                        bi = _tab_lin(tt, 2, xt)
                        acc += ((ar * br - ai * bi) * interp_one(sig, u, table)
                                - (ar * bi + ai * br) * interp_one(sigq, u, table))
                out[k0 + k, ch] += scale * acc


#: The same kernel compiled serially, for short windows (as ``echo_accumulate_serial``).
echo_table_accumulate_serial = njit(cache=True, fastmath=True)(echo_table_accumulate.py_func)
