"""Numba kernels of the frequency-domain conventional beamformer (thesis eq. 2.8).

The CBF output for beam b at bin f and snapshot s is

    Y[s, f, b] = sum_n w_n exp(-j 2 pi f tau_{b,n}) X[s, f, n]

with ``tau_{b,n} = (r_n - r_ref) . k_b / c`` (s) the advance of element n over the phase
reference for a plane wave from unit direction ``k_b``, and ``w_n`` the array shading. The
stage evaluates it as a *real* GEMM per bin: the steering rows ``cos``/``-sin`` of one
direction multiply the stacked real and imaginary parts of the snapshots, ``[Xr | Xi]``. A
direction and its opposite (cone angles θ and 180° − θ) have conjugate steering vectors, so one
pair of real columns serves both beams: with ``P = [Xr; Xi]·C`` and ``Q = [Xr; Xi]·S``,

    Y(+k) = (Pr - Qi) + j (Pi + Qr),     Y(-k) = (Pr + Qi) + j (Pi - Qr),

which halves the arithmetic of a complex GEMM for symmetric beam fans. The kernels below pack
the FFT output into the GEMM layout, build the steering matrix and unpack the GEMM result.
All are ``nogil`` so the stage can run them on several threads (one range of bins each).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def window_transpose(frames: np.ndarray, win: np.ndarray, out: np.ndarray) -> None:
    """``out[s, c, k] = win[k] · frames[s, k, c]``: taper the frames (S, nfft, C) and lay each
    channel's samples contiguously for the FFT. ``out`` has at least S rows."""
    ns, nk, nc = frames.shape
    tile = 32  # transpose in tiles so both sides stay in cache
    for s in range(ns):
        for k0 in range(0, nk, tile):
            k1 = min(nk, k0 + tile)
            for c in range(nc):
                for k in range(k0, k1):
                    out[s, c, k] = win[k] * frames[s, k, c]


@njit(cache=True, nogil=True)
def pack_bins(spec: np.ndarray, first_bin: int, out: np.ndarray) -> None:
    """Copy bins ``first_bin .. first_bin + out.shape[0]`` of ``spec`` (S, C, F) complex into
    ``out`` (nf, 2S, C) float32: rows 0..S-1 the real parts, rows S..2S-1 the imaginary."""
    nf, s2, nc = out.shape
    ns = s2 // 2
    for s in range(ns):
        for c in range(nc):
            for f in range(nf):
                v = spec[s, c, first_bin + f]
                out[f, s, c] = v.real
                out[f, ns + s, c] = v.imag


@njit(cache=True, nogil=True)
def steering_real(freqs: np.ndarray, delays: np.ndarray, weights: np.ndarray,
                  out: np.ndarray) -> None:
    """Real steering columns for the GEMM: ``out[f, n, 2u] = w_n cos(2π f τ_un)`` and
    ``out[f, n, 2u+1] = -w_n sin(2π f τ_un)``.

    freqs (F,) Hz; delays (U, C) s; weights (C,); out (F, C, 2U) float32.
    """
    nf = freqs.shape[0]
    nu, nc = delays.shape
    for f in range(nf):
        w0 = 2.0 * math.pi * freqs[f]
        for n in range(nc):
            for u in range(nu):
                ph = w0 * delays[u, n]
                out[f, n, 2 * u] = weights[n] * math.cos(ph)
                out[f, n, 2 * u + 1] = -weights[n] * math.sin(ph)


@njit(cache=True, nogil=True)
def unpack_beams(z: np.ndarray, uidx: np.ndarray, sign: np.ndarray, y: np.ndarray,
                 f_off: int) -> None:
    """Combine the real GEMM result ``z`` (nf, 2S, 2U) = [Xr; Xi]·[C | S] into complex beams.

    ``y`` (S, F, B) complex64 receives bins ``f_off .. f_off + nf``; beam b uses direction
    ``uidx[b]`` with ``sign[b]`` = +1 (the direction itself) or -1 (its opposite).
    """
    nf = z.shape[0]
    ns = z.shape[1] // 2
    nb = uidx.shape[0]
    for f in range(nf):
        for s in range(ns):
            for b in range(nb):
                u = uidx[b]
                sg = sign[b]
                pr = z[f, s, 2 * u]
                qr = z[f, s, 2 * u + 1]
                pi = z[f, ns + s, 2 * u]
                qi = z[f, ns + s, 2 * u + 1]
                y[s, f_off + f, b] = complex(pr - sg * qi, pi + sg * qr)


@njit(cache=True, nogil=True)
def abs2(y: np.ndarray, out: np.ndarray) -> None:
    """``out = |y|²`` elementwise for flat complex64 ``y`` into flat float32 ``out``."""
    for i in range(y.shape[0]):
        v = y[i]
        out[i] = v.real * v.real + v.imag * v.imag


@njit(cache=True, nogil=True)
def window_sums(p: np.ndarray, n: int, step: int, out: np.ndarray) -> None:
    """Sums of ``n`` consecutive snapshots of ``p`` (T, M) every ``step`` snapshots.

    ``out`` (K, M) with K = (T - n) // step + 1; accumulates in float64 (thesis eq. 2.22).
    """
    k_out = out.shape[0]
    m = p.shape[1]
    acc = np.zeros(m)
    for k in range(k_out):
        a = k * step
        if k == 0 or step >= n:
            acc[:] = 0.0
            for j in range(a, a + n):
                for i in range(m):
                    acc[i] += p[j, i]
        else:  # slide: drop the snapshots that left, add the ones that came in
            for j in range(a - step, a):
                for i in range(m):
                    acc[i] -= p[j, i]
            for j in range(a + n - step, a + n):
                for i in range(m):
                    acc[i] += p[j, i]
        for i in range(m):
            out[k, i] = acc[i]
