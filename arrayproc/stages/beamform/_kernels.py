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
from numba import njit, uint64


@njit(cache=True, nogil=True)
def window_frame(x: np.ndarray, offset: int, w: np.ndarray, out: np.ndarray) -> None:
    """``out[t, c] = w[t] · x[offset + t, c]``: one frame of the time-major stream buffer ``x``
    (T, C) windowed into the (N, C) FFT input (transformed along its first axis)."""
    n, nc = out.shape
    o = uint64(offset)  # unsigned: no negative-index wraparound in the loop
    for t in range(uint64(n)):
        wt = w[t]
        row = x[o + t]
        orow = out[t]
        for c in range(nc):
            orow[c] = wt * row[c]


@njit(cache=True, nogil=True)
def pack_bins(spec: np.ndarray, first_bin: int, out: np.ndarray) -> None:
    """Bins ``first_bin .. first_bin + nf`` of one snapshot's spectrum ``spec`` (F, C)
    complex, split into ``out`` (2, nf, C) float32: real parts in ``out[0]``, imaginary parts
    in ``out[1]``. One snapshot's output is contiguous, so the writes stream (the corner turn
    to per-bin order is :func:`gather_bins`, from cache-sized pieces)."""
    nf, nc = out.shape[1], out.shape[2]
    for f in range(uint64(nf)):
        row = spec[uint64(first_bin) + f]
        o_r = out[0, f]
        o_i = out[1, f]
        for c in range(nc):
            v = row[c]
            o_r[c] = v.real
            o_i[c] = v.imag


@njit(cache=True, nogil=True)
def gather_bins(q: np.ndarray, first_bin: int, out: np.ndarray) -> None:
    """The corner turn: bins ``first_bin .. first_bin + n`` of the per-snapshot arrays ``q``
    (S, 2, nf, W) into the per-bin GEMM operands ``out`` (n, 2S, W): row s holds snapshot s's
    ``q[s, 0]`` (real parts), row S + s its ``q[s, 1]`` (imaginary parts). Each source piece
    is n·W contiguous floats and the destination fits in cache."""
    ns = q.shape[0]
    n, nw = out.shape[0], out.shape[2]
    f0 = uint64(first_bin)
    for s in range(uint64(ns)):
        for p in range(uint64(2)):
            r = p * uint64(ns) + s
            for f in range(uint64(n)):
                src = q[s, p, f0 + f]
                dst = out[f, r]
                for k in range(uint64(nw)):
                    dst[k] = src[k]


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
    for s in range(ns):  # s outer: y[s, f_off:f_off+nf, :] is one contiguous run of memory
        for f in range(nf):
            for b in range(nb):
                u = uidx[b]
                sg = sign[b]
                pr = z[f, s, 2 * u]
                qr = z[f, s, 2 * u + 1]
                pi = z[f, ns + s, 2 * u]
                qi = z[f, ns + s, 2 * u + 1]
                y[s, f_off + f, b] = complex(pr - sg * qi, pi + sg * qr)


# -- centro-symmetric arrays (e.g. uniform line arrays): fold element pairs --------------------
# Elements i and j with r_i − r̄ = −(r_j − r̄) and equal shading have opposite delays, so
#   w e^{−jφ} X_i + w e^{+jφ} X_j = w cos φ (X_i + X_j) − j w sin φ (X_i − X_j),
# and a beam is Y = A − jB with A = Σ_k w_k cos φ_k S_k, B = Σ_k w_k sin φ_k D_k over the K
# pairs (S = X_i + X_j, D = X_i − X_j): two real GEMMs of depth K = N/2 instead of one of depth
# N, half the arithmetic again. The opposite direction is A + jB.


@njit(cache=True, nogil=True)
def pack_fold(spec: np.ndarray, first_bin: int, pi: np.ndarray, pj: np.ndarray,
              out_s: np.ndarray, out_d: np.ndarray) -> None:
    """Sums and differences of element pairs (pi[k], pj[k]) for bins ``first_bin .. +nf`` of
    one snapshot's spectrum ``spec`` (F, C), into ``out_s``/``out_d`` (2, nf, K): real parts
    in ``[0]``, imaginary parts in ``[1]``. A centre element (pi == pj) gives S = X, D = 0."""
    nf, nk = out_s.shape[1], out_s.shape[2]
    for f in range(uint64(nf)):
        row = spec[uint64(first_bin) + f]
        sr = out_s[0, f]
        si = out_s[1, f]
        dr = out_d[0, f]
        di = out_d[1, f]
        for k in range(uint64(nk)):
            i = uint64(pi[k])
            j = uint64(pj[k])
            a = row[i]
            if j != i:
                b = row[j]
                sr[k] = a.real + b.real
                si[k] = a.imag + b.imag
                dr[k] = a.real - b.real
                di[k] = a.imag - b.imag
            else:
                sr[k] = a.real
                si[k] = a.imag
                dr[k] = 0.0
                di[k] = 0.0


@njit(cache=True, nogil=True)
def steering_fold(freqs: np.ndarray, delays: np.ndarray, weights: np.ndarray,
                  out_c: np.ndarray, out_s: np.ndarray) -> None:
    """``out_c[f, k, u] = w_k cos(2π f τ_uk)``, ``out_s[f, k, u] = w_k sin(2π f τ_uk)`` for the
    first element of each pair; freqs (F,), delays (U, K) s, weights (K,), outs (F, K, U)."""
    nf = freqs.shape[0]
    nu, nk = delays.shape
    for f in range(nf):
        w0 = 2.0 * math.pi * freqs[f]
        for k in range(nk):
            for u in range(nu):
                ph = w0 * delays[u, k]
                out_c[f, k, u] = weights[k] * math.cos(ph)
                out_s[f, k, u] = weights[k] * math.sin(ph)


def beam_runs(uidx: np.ndarray, sign: np.ndarray) -> np.ndarray:
    """Compress the beam → (direction, sign) map into linear runs ``(b0, n, u0, du, sign)``
    (int64 rows; sign ±1) so the unpack loops run over contiguous indices. A symmetric fan
    0..180° is two runs: beams up to 90° forwards, the rest backwards."""
    runs = []
    b = 0
    nb = len(uidx)
    while b < nb:
        n = 1
        du = int(uidx[b + 1] - uidx[b]) if b + 1 < nb else 1
        if du not in (1, -1):
            du = 1
        while (b + n < nb and sign[b + n] == sign[b]
               and uidx[b + n] == uidx[b] + n * du):
            n += 1
        runs.append((b, n, int(uidx[b]), du, int(sign[b])))
        b += n
    return np.array(runs, np.int64).reshape(-1, 5)


@njit(cache=True, nogil=True)
def unpack_fold(za: np.ndarray, zb: np.ndarray, runs: np.ndarray, y: np.ndarray,
                f_off: int) -> None:
    """Beams from the folded GEMMs ``za`` = [Sr; Si]·C and ``zb`` = [Dr; Di]·S, (nf, 2S, U):
    Y(+u) = A − jB = (Ar + Bi) + j(Ai − Br), Y(−u) = A + jB, into y (S, F, B) complex64;
    ``runs`` from :func:`beam_runs`. Each beam is written once, straight from the GEMM rows."""
    nf = za.shape[0]
    ns = za.shape[1] // 2
    for s in range(ns):  # s outer: y[s, f_off:f_off+nf, :] is one contiguous run of memory
        for f in range(nf):
            ar = za[f, s]
            ai = za[f, ns + s]
            br = zb[f, s]
            bi = zb[f, ns + s]
            out = y[s, f_off + f]
            for r in range(runs.shape[0]):
                # unsigned indices: numba then emits no negative-index wraparound, and with
                # constant unit strides the loops vectorise (2-3x faster, docs/performance.md)
                b0, n, u0 = uint64(runs[r, 0]), uint64(runs[r, 1]), uint64(runs[r, 2])
                fwd = runs[r, 3] == 1
                if runs[r, 4] > 0:
                    if fwd:
                        for m in range(n):
                            out[b0 + m] = complex(ar[u0 + m] + bi[u0 + m],
                                                  ai[u0 + m] - br[u0 + m])
                    else:
                        for m in range(n):
                            out[b0 + m] = complex(ar[u0 - m] + bi[u0 - m],
                                                  ai[u0 - m] - br[u0 - m])
                elif fwd:
                    for m in range(n):
                        out[b0 + m] = complex(ar[u0 + m] - bi[u0 + m], ai[u0 + m] + br[u0 + m])
                else:
                    for m in range(n):
                        out[b0 + m] = complex(ar[u0 - m] - bi[u0 - m], ai[u0 - m] + br[u0 - m])
