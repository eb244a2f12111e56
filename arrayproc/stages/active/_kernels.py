"""Numba kernels of the active chain: the exact frequency-domain beamformer of a ping window,
the square-law power of the matched-filter rows and the CFAR detectors (CA, GO, SO, OS over
range or range x Doppler). Each has a plain-numpy reference in ``tests/stages/active``.

Written by hand because no maintained library streams a CFAR over a range x Doppler plane with
edge-aware training counts, or steers a wideband line array exactly per DFT bin without
building the (bins, elements, beams) steering array.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

MODE_CA, MODE_GO, MODE_SO, MODE_OS = 0, 1, 2, 3


@njit(parallel=True, cache=True, nogil=True)
def steer_bins(x: np.ndarray, f0: float, df: float, tau: np.ndarray, w: np.ndarray,
               out: np.ndarray) -> None:  # pragma: no cover - numba
    """Delay-and-sum of DFT bins, exact per bin (thesis eq. (2.8)).

    ``out[b, k] = sum_c w[c] x[c, k] exp(-2j pi (f0 + k df) tau[b, c])`` for x (C, K) complex128,
    tau (B, C) s (element advances), w (C,) shading; out (B, K) complex64. The phase runs by
    recurrence along the bins (one complex multiply per bin and element).
    """
    nb, nc = tau.shape
    nk = x.shape[1]
    for b in prange(nb):
        acc = np.zeros(nk, np.complex128)
        for c in range(nc):
            ph = w[c] * np.exp(-2j * np.pi * f0 * tau[b, c])
            st = np.exp(-2j * np.pi * df * tau[b, c])
            for k in range(nk):
                acc[k] += x[c, k] * ph
                ph *= st
        for k in range(nk):
            out[b, k] = acc[k]


@njit(parallel=True, cache=True, nogil=True)
def power(z: np.ndarray, out: np.ndarray) -> None:  # pragma: no cover - numba
    """Square law ``out = |z|^2`` (float32) of a 2-D complex array, rows in parallel."""
    for i in prange(z.shape[0]):
        for j in range(z.shape[1]):
            v = z[i, j]
            out[i, j] = v.real * v.real + v.imag * v.imag


@njit(cache=True, nogil=True)
def mul_rows(bank: np.ndarray, spec: np.ndarray, out: np.ndarray) -> None:  # pragma: no cover
    """``out[d, k] = bank[d, k] * spec[k]`` (complex64), one thread (callers thread by beam)."""
    for d in range(bank.shape[0]):
        for k in range(bank.shape[1]):
            out[d, k] = bank[d, k] * spec[k]


@njit(cache=True, nogil=True)
def power_rows(z: np.ndarray, r0: int, out: np.ndarray) -> None:  # pragma: no cover - numba
    """``out[d, j] = |z[d, r0 + j]|^2`` (float32), one thread. Reads z as interleaved float32
    (re, im) pairs from index 0 of each row's slice, a loop LLVM vectorises (2.5x the
    complex-element loop measured; the same float32 arithmetic, so the same bytes)."""
    f = z.view(np.float32)
    n = out.shape[1]
    for d in range(out.shape[0]):
        row = f[d, 2 * r0:2 * (r0 + n)]
        o = out[d]
        for j in range(n):
            a = row[2 * j]
            b = row[2 * j + 1]
            o[j] = a * a + b * b


@njit(cache=True, nogil=True)
def _interior_flags(row: np.ndarray, cs: np.ndarray, g: int, t: int, mode: int,
                    a_full: float, a_half: float, r0: int, r1: int,
                    hit: np.ndarray) -> None:  # pragma: no cover - numba
    """``hit[r - r0] = 1`` where cell r of the row is over the 1-D CA/GO/SO threshold (window
    inside the row): branch-free loops that LLVM vectorises, one per mode."""
    w = g + t
    inv_t = 1.0 / t
    inv_n = 0.5 / t
    m = r1 - r0
    # the four prefix-sum terms and the cells as views from index 0 (no negative-index
    # wrap-around test in the loops, which then vectorise)
    x = row[r0:r1]
    c1 = cs[r0 - g:r1 - g]
    c2 = cs[r0 - w:r1 - w]
    c3 = cs[r0 + w + 1:r1 + w + 1]
    c4 = cs[r0 + g + 1:r1 + g + 1]
    h = hit[:m]
    if mode == MODE_CA:
        for i in range(m):
            est = ((c1[i] - c2[i]) + (c3[i] - c4[i])) * inv_n
            h[i] = (x[i] > a_full * est) & (est > 0.0)
    elif mode == MODE_GO:
        for i in range(m):
            est = max(c1[i] - c2[i], c3[i] - c4[i]) * inv_t
            h[i] = (x[i] > a_half * est) & (est > 0.0)
    else:
        for i in range(m):
            est = min(c1[i] - c2[i], c3[i] - c4[i]) * inv_t
            h[i] = (x[i] > a_half * est) & (est > 0.0)


@njit(cache=True, nogil=True)
def _ca_row_interior(row: np.ndarray, cs: np.ndarray, g: int, t: int, mode: int, a_full: float,
                     a_half: float, r0: int, r1: int, d: int, rows: np.ndarray,
                     cols: np.ndarray, vals: np.ndarray, noise: np.ndarray,
                     n: int, hit: np.ndarray) -> int:  # pragma: no cover - numba
    """1-D CA/GO/SO over the cells of one row whose window lies inside the row (constant N):
    the fast path of :func:`cfar_plane`. ``cs`` is the row's prefix sum; ``hit`` a uint8
    scratch of at least r1 - r0 cells. The threshold test runs vectorised over the row
    (:func:`_interior_flags`), then the few cells over it are recorded with the same
    estimate."""
    w = g + t
    inv_t = 1.0 / t
    inv_n = 0.5 / t
    cap = rows.size
    _interior_flags(row, cs, g, t, mode, a_full, a_half, r0, r1, hit)
    h64 = hit[:(r1 - r0) // 8 * 8].view(np.uint64)
    for q in range(h64.size + 1):
        if q < h64.size and h64[q] == 0:
            continue
        lo = r0 + 8 * q
        hi = min(r1, lo + 8) if q < h64.size else r1
        for r in range(lo, hi):
            if hit[r - r0] == 0:
                continue
            s1 = cs[r - g] - cs[r - w]
            s2 = cs[r + w + 1] - cs[r + g + 1]
            if mode == MODE_CA:
                est = (s1 + s2) * inv_n
            elif mode == MODE_GO:
                est = max(s1, s2) * inv_t
            else:
                est = min(s1, s2) * inv_t
            if n < cap:
                rows[n] = d
                cols[n] = r
                vals[n] = row[r]
                noise[n] = est
            n += 1
    return n


@njit(cache=True, nogil=True)
def _prefix(v: np.ndarray, out: np.ndarray) -> None:  # pragma: no cover - numba
    s = 0.0
    out[0] = 0.0
    for i in range(v.size):
        s += v[i]
        out[i + 1] = s


@njit(cache=True, nogil=True)
def _prefix4(p: np.ndarray, d0: int, out: np.ndarray) -> None:  # pragma: no cover - numba
    """Prefix sums of rows d0 ... d0 + 3 of p (fewer at the end) into out[0 ... 3], the four
    running sums interleaved (four independent addition chains; each row's additions in
    the same order as :func:`_prefix`, so the same values)."""
    m = min(4, p.shape[0] - d0)
    if m < 4:
        for i in range(m):
            _prefix(p[d0 + i], out[i])
        return
    s0 = 0.0
    s1 = 0.0
    s2 = 0.0
    s3 = 0.0
    out[0, 0] = 0.0
    out[1, 0] = 0.0
    out[2, 0] = 0.0
    out[3, 0] = 0.0
    for i in range(p.shape[1]):
        s0 += p[d0, i]
        s1 += p[d0 + 1, i]
        s2 += p[d0 + 2, i]
        s3 += p[d0 + 3, i]
        out[0, i + 1] = s0
        out[1, i + 1] = s1
        out[2, i + 1] = s2
        out[3, i + 1] = s3


@njit(cache=True, nogil=True)
def _column_prefix(p: np.ndarray, fa: int, fb: int, ga: int, gb: int, colf: np.ndarray,
                   colg: np.ndarray, ff: np.ndarray, gg: np.ndarray) -> None:  # pragma: no cover
    """2-D CFAR: per column the sums of rows [fa, fb) (window) and [ga, gb) (guard), and
    their prefix sums along range."""
    for r in range(p.shape[1]):
        sf = 0.0
        for i in range(fa, fb):
            sf += p[i, r]
        sg = 0.0
        for i in range(ga, gb):
            sg += p[i, r]
        colf[r] = sf
        colg[r] = sg
    _prefix(colf, ff)
    _prefix(colg, gg)


@njit(cache=True, nogil=True)
def _kth(buf: np.ndarray, n: int, k: int) -> float:  # pragma: no cover - numba
    """k-th smallest (1-based) of buf[:n] (partial selection sort of a copy)."""
    a = buf[:n].copy()
    a.sort()
    return a[k - 1]


@njit(cache=True, nogil=True)
def cfar_plane(p: np.ndarray, gd: int, td: int, gr: int, tr: int, mode: int,
               alpha_n: np.ndarray, alpha_half: float, half_n: int, os_k: np.ndarray,
               r0: int, r1: int, rows: np.ndarray, cols: np.ndarray, vals: np.ndarray,
               noise: np.ndarray) -> int:  # pragma: no cover - numba
    """CFAR over a (D, R) square-law plane: Doppler rows, range columns.

    The training cells of cell (d, r) are the rectangle rows d +- (gd + td), columns
    r +- (gr + tr) minus the guard rectangle rows d +- gd, columns r +- gr, clipped to the plane;
    1-D range CFAR is ``gd = td = 0``. Noise estimate: CA the mean of all N training cells; GO /
    SO the larger / smaller of the means of the lead (columns < r) and lag (columns > r) halves
    when both hold ``half_n`` cells (else CA); OS the ``os_k[N]``-th smallest training cell.
    Threshold ``alpha * estimate`` with ``alpha = alpha_n[N]`` (CA, OS and edge cells) or
    ``alpha_half`` (GO/SO interior). Only columns r0 <= r < r1 are tested; a cell whose noise
    estimate is 0 (training cells of exact zeros, e.g. past the data) is never detected.

    Writes detections into rows/cols/vals/noise (capacity = their length) and returns their
    count, or -(count needed) when the capacity is too small (nothing useful written then).
    """
    nd, nr = p.shape
    wd, wr = gd + td, gr + tr
    ff0 = np.zeros(nr + 1)
    gg0 = np.zeros(nr + 1)
    pf = np.zeros((4, nr + 1))
    hit = np.zeros(nr, np.uint8)
    ff = ff0
    gg = gg0
    colf = np.zeros(nr)
    colg = np.zeros(nr)
    cap = rows.size
    n = 0
    buf = np.empty((2 * wd + 1) * (2 * wr + 1))
    for d in range(nd):
        fa, fb = max(0, d - wd), min(nd, d + wd + 1)
        ga, gb = max(0, d - gd), min(nd, d + gd + 1)
        nf, ng = fb - fa, gb - ga
        one_d = wd == 0
        if mode != MODE_OS and one_d:  # 1-D: the row's own prefix sums serve both
            if d % 4 == 0:
                _prefix4(p, d, pf)
            ff = pf[d % 4]
            gg = ff
        elif mode != MODE_OS:
            ff = ff0
            gg = gg0
            _column_prefix(p, fa, fb, ga, gb, colf, colg, ff, gg)
        fast = mode != MODE_OS and wd == 0 and gd == 0
        ia, ib = r0, r0  # interior handled by the fast path: none unless fast
        if fast:  # interior columns by the constant-N fast path, edges below
            ia, ib = max(r0, wr), min(r1, nr - wr)
            if ib > ia:
                n = _ca_row_interior(p[d], ff, gr, tr, mode, alpha_n[2 * tr], alpha_half, ia,
                                     ib, d, rows, cols, vals, noise, n, hit)
            else:
                ia, ib = r0, r0
        n_seg = 2 if ib > ia else 1
        for seg in range(n_seg):
            sa, sb = (r0, ia) if n_seg == 2 and seg == 0 else ((ib, r1) if n_seg == 2
                                                               else (r0, r1))
            for r in range(sa, sb):
                x = p[d, r]
                # lead: columns [r - wr, r - 1], guard part [r - gr, r - 1]; lag mirrored
                la, lb = max(0, r - wr), r
                ka, kb = max(0, r - gr), r
                ua, ub = r + 1, min(nr, r + wr + 1)
                va, vb = r + 1, min(nr, r + gr + 1)
                n_lead = nf * (lb - la) - ng * (kb - ka)
                n_lag = nf * (ub - ua) - ng * (vb - va)
                n_mid = nf - ng  # the cut's own column outside the guard rows
                ntot = n_lead + n_lag + n_mid
                if ntot <= 0:
                    continue
                if mode == MODE_OS:
                    m = 0
                    for i in range(fa, fb):
                        inguard_row = ga <= i < gb
                        for j in range(max(0, r - wr), min(nr, r + wr + 1)):
                            if inguard_row and r - gr <= j <= r + gr:
                                continue
                            buf[m] = p[i, j]
                            m += 1
                    k = os_k[m]
                    lim = x / alpha_n[m]
                    cnt = 0
                    for i in range(m):
                        if buf[i] < lim:
                            cnt += 1
                    if cnt >= k and _kth(buf, m, k) > 0.0:
                        if n < cap:
                            rows[n] = d
                            cols[n] = r
                            vals[n] = x
                            noise[n] = _kth(buf, m, k)
                        n += 1
                    continue
                s_lead = (ff[lb] - ff[la]) - (gg[kb] - gg[ka])
                s_lag = (ff[ub] - ff[ua]) - (gg[vb] - gg[va])
                s_mid = 0.0 if one_d else colf[r] - colg[r]
                if (mode == MODE_GO or mode == MODE_SO) and n_lead == half_n and n_lag == half_n:
                    m1 = s_lead / n_lead
                    m2 = s_lag / n_lag
                    est = max(m1, m2) if mode == MODE_GO else min(m1, m2)
                    a = alpha_half
                else:
                    est = (s_lead + s_lag + s_mid) / ntot
                    a = alpha_n[ntot]
                if x > a * est and est > 0.0:
                    if n < cap:
                        rows[n] = d
                        cols[n] = r
                        vals[n] = x
                        noise[n] = est
                    n += 1
    if n > cap:
        return -n
    return n
