"""Numba kernels of passive synthetic aperture processing (thesis ch. 2.1.2.2 and 2.2.3).

Conventions: element spectra X (F, C) are ordered from the forward end aft, element n at body
x = x_0 − n δx; a plane wave from cone angle θ (u = cos θ) reaches element n with the phase
factor exp(+j 2π f x_n u / c) (numpy's DFT sign), and a beam removes it:
Y(θ, f) = Σ_n X_n(f) exp(−j 2π f (x_n − x̄) u / c) — thesis eq. (2.8) with the DFT sign of
numpy. References in plain numpy sit in ``tests/stages/beamform/test_synthetic_kernels.py``.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

TWO_PI = 2.0 * np.pi


@njit(cache=True, parallel=True, fastmath=False)
def subaperture_beams(x: np.ndarray, freqs: np.ndarray, u: np.ndarray, x0: float, dx: float,
                      c: float, out: np.ndarray) -> None:
    """Physical-aperture beams of one snapshot, thesis eq. (2.8), uniform line array.

    ``x`` (F, C) complex64 element spectra (fore → aft), ``freqs`` (F,) Hz, ``u`` (B,) = cos θ,
    ``x0`` body x of element 0 relative to the array centroid (m), ``dx`` spacing (m),
    ``out`` (F, B) complex64. The geometric progression of the steering phases over the
    elements is summed by Horner's rule: Σ_n X_n w_0 r^n with w_0 = exp(−j2πf x0 u/c) and
    r = exp(+j2πf δx u/c).
    """
    n_f, n_c = x.shape
    n_b = u.shape[0]
    for f in prange(n_f):
        k = TWO_PI * freqs[f] / c
        # single precision accumulators: 8 SIMD lanes; the 64-step recurrence keeps ~1e-6
        acc_re = np.empty(n_b, np.float32)
        acc_im = np.empty(n_b, np.float32)
        r_re = np.empty(n_b, np.float32)
        r_im = np.empty(n_b, np.float32)
        for b in range(n_b):
            ph = k * dx * u[b]
            r_re[b] = np.cos(ph)
            r_im[b] = np.sin(ph)
            acc_re[b] = x[f, n_c - 1].real
            acc_im[b] = x[f, n_c - 1].imag
        for n in range(n_c - 2, -1, -1):
            xr = np.float32(x[f, n].real)
            xi = np.float32(x[f, n].imag)
            for b in range(n_b):
                ar = acc_re[b] * r_re[b] - acc_im[b] * r_im[b] + xr
                ai = acc_re[b] * r_im[b] + acc_im[b] * r_re[b] + xi
                acc_re[b] = ar
                acc_im[b] = ai
        for b in range(n_b):
            ph = -k * x0 * u[b]
            wr = np.cos(ph)
            wi = np.sin(ph)
            out[f, b] = complex(acc_re[b] * wr - acc_im[b] * wi, acc_re[b] * wi + acc_im[b] * wr)


@njit(cache=True, parallel=True)
def combine_subapertures(beams: np.ndarray, order: np.ndarray, phase: np.ndarray,
                         disp: np.ndarray, freqs: np.ndarray, u: np.ndarray, c: float,
                         out: np.ndarray) -> None:
    """Synthetic-aperture beams from sub-aperture beams, thesis eqs. (2.33)-(2.35).

    Y(θ, f) = Σ_s B_s(θ, f) · exp(j Φ_s(f)) · exp(−j 2π f D_s u / c)

    ``beams`` (R, B, F) complex64, a ring of sub-aperture beams (beam-major so that the
    frequency runs contiguously); ``order`` (S,) the ring slots of the window's snapshots;
    ``phase`` (S, F) complex128, exp(j Φ_s(f)) — the inter-snapshot correction (−2π f
    (t_s − t_1) for ideal PSAS, the accumulated ETAM correction of eq. (2.53) otherwise);
    ``disp`` (S,) along-track displacement D_s of each snapshot's array centre from the first
    (m); ``freqs`` (F,) Hz, uniformly spaced; ``u`` (B,) = cos θ; ``out`` (F, B) complex64.
    The displacement steering advances along frequency by a complex recurrence, re-anchored
    every 256 bins against rounding drift.
    """
    n_s = order.shape[0]
    n_b = u.shape[0]
    n_f = freqs.shape[0]
    df = freqs[1] - freqs[0] if n_f > 1 else 0.0
    for b in prange(n_b):
        acc = np.zeros(n_f, np.complex128)
        for s in range(n_s):
            slot = order[s]
            a = -TWO_PI * disp[s] * u[b] / c
            step = complex(np.cos(a * df), np.sin(a * df))
            e = 1.0 + 0.0j
            for f in range(n_f):
                if f % 256 == 0:
                    e = complex(np.cos(a * freqs[f]), np.sin(a * freqs[f]))
                acc[f] += beams[slot, b, f] * (e * phase[s, f])
                e *= step
        for f in range(n_f):
            out[f, b] = acc[f]


@njit(cache=True)
def etam_phase(xa: np.ndarray, xb: np.ndarray, shift: int, q: int, out: np.ndarray) -> None:
    """ETAM phase correction between successive snapshots, thesis eqs. (2.53)-(2.54).

    ``xa`` (F, C) spectra of snapshot b, ``xb`` of snapshot b+1, elements ordered fore → aft.
    Between the two the array moved ``shift`` elements forward, so element n + shift of b+1
    sits where element n of b was: b's forward elements and b+1's aft elements overlap. For
    each bin l,

        Ψ_b(f_l) = arg( Σ_n ρ_n(f_l) Ξ_{b,n}(f_l) Ξ*_{b+1,n+shift}(f_l) / Σ_n ρ_n(f_l) ),

    with ρ_n the coherence of the pair over the ``q`` bins centred on l (eq. 2.54, truncated
    at the band edges). (The thesis writes the pair as Ξ_{b,N_H/2+n} Ξ*_{b+1,n}, numbering the
    elements the other way round.) Multiplying snapshot b+1 by exp(jΨ_b) aligns its phase with
    snapshot b. ``out`` (F,) float64.
    """
    n_f, n_c = xa.shape
    n_pair = n_c - shift
    h = q // 2
    # Cumulative sums over frequency of the pair products and powers: ρ over any window in O(1).
    cs = np.zeros((n_f + 1, n_pair), np.complex128)
    pa = np.zeros((n_f + 1, n_pair))
    pb = np.zeros((n_f + 1, n_pair))
    for f in range(n_f):
        for n in range(n_pair):
            a = xa[f, n]
            b = xb[f, n + shift]
            cs[f + 1, n] = cs[f, n] + a * np.conj(b)
            pa[f + 1, n] = pa[f, n] + a.real * a.real + a.imag * a.imag
            pb[f + 1, n] = pb[f, n] + b.real * b.real + b.imag * b.imag
    for f in range(n_f):
        lo = max(0, f - h)
        hi = min(n_f, f + h + 1)
        num = 0.0 + 0.0j
        for n in range(n_pair):
            den = np.sqrt((pa[hi, n] - pa[lo, n]) * (pb[hi, n] - pb[lo, n]))
            rho = np.abs(cs[hi, n] - cs[lo, n]) / den if den > 0 else 0.0
            num += rho * (xa[f, n] * np.conj(xb[f, n + shift]))
        # Dividing by Σρ (> 0) does not change the argument.
        out[f] = np.arctan2(num.imag, num.real)


@njit(cache=True, parallel=True)
def beam_at(x: np.ndarray, freqs: np.ndarray, u: np.ndarray, x0: float, dx: float, c: float,
            out: np.ndarray) -> None:
    """One beam per bin: out[f] = Σ_n X[f, n] exp(−j2π f x_n u[f] / c), x_n = x0 − n δx.

    The exact matched filter of a plane wave from direction cosine ``u[f]`` (eq. 2.8), used to
    refine directions in the inverse beamformer. ``x`` (F, C) complex128, ``out`` (F,)
    complex128.
    """
    n_f, n_c = x.shape
    for f in prange(n_f):
        k = TWO_PI * freqs[f] * u[f] / c
        r = complex(np.cos(k * dx), np.sin(k * dx))
        acc = x[f, n_c - 1]
        for n in range(n_c - 2, -1, -1):
            acc = acc * r + x[f, n]
        out[f] = acc * complex(np.cos(-k * x0), np.sin(-k * x0))


@njit(cache=True)
def _solve_small(G: np.ndarray, b: np.ndarray, out: np.ndarray) -> None:
    """Solve the K×K complex system G a = b by Gaussian elimination with partial pivoting
    (G and b are overwritten)."""
    k = b.shape[0]
    for i in range(k):
        p = i
        for r in range(i + 1, k):
            if abs(G[r, i]) > abs(G[p, i]):
                p = r
        if p != i:
            for c in range(k):
                G[i, c], G[p, c] = G[p, c], G[i, c]
            b[i], b[p] = b[p], b[i]
        piv = G[i, i]
        if abs(piv) == 0.0:
            piv = 1e-300
        for r in range(i + 1, k):
            m = G[r, i] / piv
            for c in range(i, k):
                G[r, c] -= m * G[i, c]
            b[r] -= m * b[i]
    for i in range(k - 1, -1, -1):
        s = b[i]
        for c in range(i + 1, k):
            s -= G[i, c] * out[c]
        piv = G[i, i] if abs(G[i, i]) > 0.0 else 1e-300
        out[i] = s / piv


@njit(cache=True)
def _fit_amplitudes(xrow: np.ndarray, kk: float, u: np.ndarray, x0: float, dx: float,
                    V: np.ndarray, G: np.ndarray, b: np.ndarray, a: np.ndarray) -> None:
    """One bin's plane-wave signatures V (K, C), v_k,n = exp(+j kk (x0 − n δx) u_k), and
    least-squares amplitudes a = (VᴴV + loading)⁻¹ Vᴴ x (G, b are scratch)."""
    n_k, n_c = V.shape
    for j in range(n_k):
        ph = kk * u[j]
        rr = complex(np.cos(-ph * dx), np.sin(-ph * dx))
        v = complex(np.cos(ph * x0), np.sin(ph * x0))
        for n in range(n_c):
            V[j, n] = v
            v *= rr
    for i in range(n_k):
        for j in range(n_k):
            s = 0.0 + 0.0j
            for n in range(n_c):
                s += np.conj(V[i, n]) * V[j, n]
            G[i, j] = s
        G[i, i] += 1e-9 * n_c  # loading
        s = 0.0 + 0.0j
        for n in range(n_c):
            s += np.conj(V[i, n]) * xrow[n]
        b[i] = s
    _solve_small(G, b, a)


@njit(cache=True, parallel=True)
def plane_wave_fit(x: np.ndarray, freqs: np.ndarray, u: np.ndarray, x0: float, dx: float,
                   c: float, amp: np.ndarray, hess: np.ndarray, grad: np.ndarray) -> None:
    """One variable-projection Gauss-Newton evaluation for K plane waves, bin by bin.

    Signatures v_k(f)_n = exp(+j 2π f (x0 − n δx) u_k / c) (elements fore → aft). Per bin:
    amplitudes a = (VᴴV + loading)⁻¹ Vᴴ X (``amp`` (F, K)), residual r = X − V a, Jacobian
    J_k = −a_k (j 2π f x / c) ⊙ v_k, and the bin's normal equations ``hess`` (F, K, K) =
    Re(JᴴJ) and ``grad`` (F, K) = Re(Jᴴ r). Summing them over bins gives the band-wide step
    of :func:`arrayproc.stages.beamform.ibf.joint_fit`.
    """
    n_f, n_c = x.shape
    n_k = u.shape[0]
    chunk = 64
    for ch in prange((n_f + chunk - 1) // chunk):
        # scratch allocated once per chunk of bins
        V = np.empty((n_k, n_c), np.complex128)
        J = np.empty((n_k, n_c), np.complex128)
        G = np.empty((n_k, n_k), np.complex128)
        b = np.empty(n_k, np.complex128)
        a = np.empty(n_k, np.complex128)
        r = np.empty(n_c, np.complex128)
        for f in range(ch * chunk, min(n_f, (ch + 1) * chunk)):
            kk = TWO_PI * freqs[f] / c
            _fit_amplitudes(x[f], kk, u, x0, dx, V, G, b, a)
            for n in range(n_c):
                s = x[f, n]
                for j in range(n_k):
                    s -= V[j, n] * a[j]
                r[n] = s
            for j in range(n_k):
                amp[f, j] = a[j]
                for n in range(n_c):
                    J[j, n] = -a[j] * complex(0.0, kk * (x0 - n * dx)) * V[j, n]
            for i in range(n_k):
                for j in range(n_k):
                    s = 0.0 + 0.0j
                    for n in range(n_c):
                        s += np.conj(J[i, n]) * J[j, n]
                    hess[f, i, j] = s.real
                s = 0.0 + 0.0j
                for n in range(n_c):
                    s += np.conj(J[i, n]) * r[n]
                grad[f, i] = s.real


@njit(cache=True, parallel=True)
def subtract_plane_waves(x: np.ndarray, freqs: np.ndarray, u: np.ndarray, amp: np.ndarray,
                         x0: float, dx: float, c: float, out: np.ndarray) -> None:
    """out = X − Σ_k amp[:, k] v_k: remove plane waves (direction cosines ``u`` (K,),
    amplitudes ``amp`` (F, K)) from element spectra ``x`` (F, C), elements fore → aft."""
    n_f, n_c = x.shape
    for f in prange(n_f):
        kk = TWO_PI * freqs[f] / c
        for n in range(n_c):
            out[f, n] = x[f, n]
        for j in range(u.shape[0]):
            ph = kk * u[j]
            r = complex(np.cos(-ph * dx), np.sin(-ph * dx))
            v = complex(np.cos(ph * x0), np.sin(ph * x0)) * amp[f, j]
            for n in range(n_c):
                out[f, n] -= v
                v *= r


@njit(cache=True)
def band_power_on_grid(p: np.ndarray, k0: np.ndarray, w1: np.ndarray, out: np.ndarray) -> None:
    """Σ_f of per-bin beam powers ``p`` (F, n_pad) interpolated linearly at fractional cells
    ``k0 + w1`` (F, G) (cells taken modulo n_pad): the band's beam power on a common grid of
    directions (G,)."""
    n_f, n_pad = p.shape
    n_g = out.shape[0]
    for g in range(n_g):
        out[g] = 0.0
    for f in range(n_f):
        for g in range(n_g):
            i0 = k0[f, g] % n_pad
            i1 = (i0 + 1) % n_pad
            out[g] += (1.0 - w1[f, g]) * p[f, i0] + w1[f, g] * p[f, i1]


@njit(cache=True, parallel=True)
def remove_plane_waves(x: np.ndarray, freqs: np.ndarray, u: np.ndarray, remove: np.ndarray,
                       x0: float, dx: float, c: float, out: np.ndarray, amp: np.ndarray) -> None:
    """Least-squares amplitudes of K plane waves in every bin (``amp`` (F, K)) and the spectra
    with the waves flagged in ``remove`` (K,) subtracted (``out`` (F, C)).

    Per bin: a = (VᴴV + loading)⁻¹ Vᴴ X with v_k(f)_n = exp(+j2π f (x0 − n δx) u_k / c),
    out = X − Σ_{k removed} a_k v_k. Elements fore → aft.
    """
    n_f, n_c = x.shape
    n_k = u.shape[0]
    chunk = 64
    for ch in prange((n_f + chunk - 1) // chunk):
        V = np.empty((n_k, n_c), np.complex128)
        G = np.empty((n_k, n_k), np.complex128)
        b = np.empty(n_k, np.complex128)
        a = np.empty(n_k, np.complex128)
        for f in range(ch * chunk, min(n_f, (ch + 1) * chunk)):
            kk = TWO_PI * freqs[f] / c
            _fit_amplitudes(x[f], kk, u, x0, dx, V, G, b, a)
            for n in range(n_c):
                out[f, n] = x[f, n]
            for j in range(n_k):
                amp[f, j] = a[j]
                if remove[j]:
                    for n in range(n_c):
                        out[f, n] -= a[j] * V[j, n]
