"""Numba kernels of the delay estimators (plain-numpy references in ``tests/stages/delay``).

``refine_peaks`` evaluates the band-limited cross-correlation

    r(τ) = Re Σ_k G_k exp(j 2π f_k τ),   f_k = f_0 + k Δf,

exactly at any real lag τ (the trigonometric interpolation of the inverse DFT of thesis
eq. (3.27), which Matlab's ``interpft`` approximates on a grid) and moves from an integer-lag
peak to the maximum by Newton steps on r'(τ) = 0. The exponentials of the uniform frequency
grid are advanced by complex rotations (four interleaved, so the recurrences run side by side),
so one evaluation costs a few multiply-adds per bin and no transcendental function. Written by
hand: no maintained library evaluates a DFT at arbitrary points with its derivatives.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange


@njit(cache=True, fastmath=True)
def _corr_derivs(g, f0, df, tau):
    """r(τ), r'(τ), r''(τ) of one row of the cross-spectrum (see module docstring).

    Four interleaved rotations (bins k, k+1, k+2, k+3, each stepped by 4 Δf) so that the
    recurrences do not wait on each other.
    """
    w0 = 2.0 * math.pi * f0
    dw = 2.0 * math.pi * df
    n = g.shape[0]
    d4c = math.cos(4.0 * dw * tau)
    d4s = math.sin(4.0 * dw * tau)
    c0 = math.cos(w0 * tau)
    s0 = math.sin(w0 * tau)
    c1 = math.cos((w0 + dw) * tau)
    s1 = math.sin((w0 + dw) * tau)
    c2 = math.cos((w0 + 2 * dw) * tau)
    s2 = math.sin((w0 + 2 * dw) * tau)
    c3 = math.cos((w0 + 3 * dw) * tau)
    s3 = math.sin((w0 + 3 * dw) * tau)
    ra = 0.0
    rb = 0.0
    r1a = 0.0
    r1b = 0.0
    r2a = 0.0
    r2b = 0.0
    m = n - n % 4
    for k in range(0, m, 4):
        w = w0 + k * dw
        g0 = g[k]
        g1 = g[k + 1]
        g2 = g[k + 2]
        g3 = g[k + 3]
        re0 = g0.real * c0 - g0.imag * s0
        im0 = g0.real * s0 + g0.imag * c0
        re1 = g1.real * c1 - g1.imag * s1
        im1 = g1.real * s1 + g1.imag * c1
        re2 = g2.real * c2 - g2.imag * s2
        im2 = g2.real * s2 + g2.imag * c2
        re3 = g3.real * c3 - g3.imag * s3
        im3 = g3.real * s3 + g3.imag * c3
        ra += re0 + re1
        rb += re2 + re3
        w1 = w + dw
        w2 = w + 2 * dw
        w3 = w + 3 * dw
        r1a -= w * im0 + w1 * im1
        r1b -= w2 * im2 + w3 * im3
        r2a -= w * w * re0 + w1 * w1 * re1
        r2b -= w2 * w2 * re2 + w3 * w3 * re3
        c0, s0 = c0 * d4c - s0 * d4s, s0 * d4c + c0 * d4s
        c1, s1 = c1 * d4c - s1 * d4s, s1 * d4c + c1 * d4s
        c2, s2 = c2 * d4c - s2 * d4s, s2 * d4c + c2 * d4s
        c3, s3 = c3 * d4c - s3 * d4s, s3 * d4c + c3 * d4s
    r = ra + rb
    r1 = r1a + r1b
    r2 = r2a + r2b
    for k in range(m, n):
        th = (w0 + k * dw) * tau
        c = math.cos(th)
        s = math.sin(th)
        wk = w0 + k * dw
        re = g[k].real * c - g[k].imag * s
        im = g[k].real * s + g[k].imag * c
        r += re
        r1 -= wk * im
        r2 -= wk * wk * re
    return r, r1, r2


@njit(cache=True, parallel=True)
def refine_peaks(g, rows, f0, df, tau0, lo, hi, n_iter, tol):
    """Newton search for the maximum of r(τ) of each row, kept inside [lo, hi].

    Parameters
    ----------
    g : (m_rows, n_bins) complex
        (Weighted) cross-spectrum rows.
    rows : (m,) int64
        Row of ``g`` each search runs on (several searches may share a row).
    f0, df : float
        Frequency of the first bin and the bin spacing, Hz.
    tau0 : (m,) float64
        Starting lags (s), e.g. the integer-lag peak.
    lo, hi : (m,) float64
        Bounds of each row's search, s.
    n_iter : int
        Most Newton steps.
    tol : float
        Steps shorter than this (s) end the search.

    Returns
    -------
    tau, r, r2 : (m,) float64
        Lag of the maximum (s), r there and r'' there.
    """
    m = tau0.shape[0]
    tau = np.empty(m)
    rv = np.empty(m)
    r2v = np.empty(m)
    for i in prange(m):
        t = tau0[i]
        row = rows[i]
        r, r1, r2 = _corr_derivs(g[row], f0, df, t)
        for _ in range(n_iter):
            if r2 >= 0.0:
                break
            step = -r1 / r2
            tn = min(max(t + step, lo[i]), hi[i])
            rn, r1n, r2n = _corr_derivs(g[row], f0, df, tn)
            if rn < r:  # a step that lowers the peak is refused
                break
            t, r, r1, r2 = tn, rn, r1n, r2n
            if abs(step) < tol:
                break
        tau[i] = t
        rv[i] = r
        r2v[i] = r2
    return tau, rv, r2v


@njit(cache=True, parallel=True)
def predicted_peaks(g, rows, f0, df, tau0, lo, hi):
    """One Newton step from each start: the lag it lands on (inside [lo, hi]) and the height
    r + r'²/(2|r''|) the quadratic model predicts there (r itself where r'' ≥ 0)."""
    m = tau0.shape[0]
    tau = np.empty(m)
    pk = np.empty(m)
    for i in prange(m):
        r, r1, r2 = _corr_derivs(g[rows[i]], f0, df, tau0[i])
        if r2 < 0.0:
            tau[i] = min(max(tau0[i] - r1 / r2, lo[i]), hi[i])
            pk[i] = r - 0.5 * r1 * r1 / r2
        else:
            tau[i] = tau0[i]
            pk[i] = r
    return tau, pk


@njit(cache=True, parallel=True)
def corr_at(g, f0, df, tau):
    """r(τ) and r''(τ) of each row at the given lags (s), as in :func:`refine_peaks`."""
    m = g.shape[0]
    rv = np.empty(m)
    r2v = np.empty(m)
    for i in prange(m):
        r, r1, r2 = _corr_derivs(g[i], f0, df, tau[i])
        rv[i] = r
        r2v[i] = r2
    return rv, r2v


@njit(cache=True)
def windowed_peaks(r, lo, hi, k, frac):
    """The highest local maxima of each row of ``r`` within [lo[i], hi[i]].

    A sample is a local maximum when no neighbour inside the window is higher (the window's
    ends count when they pass that test). Of the ``k`` highest, those at least ``frac`` times
    the highest (for a positive highest) are kept.

    Parameters
    ----------
    r : (m, n_lags) float
        Correlation rows on a lag axis.
    lo, hi : (m,) int64
        First and last allowed index of each row.
    k : int
        Most maxima per row.
    frac : float
        Relative height a kept maximum needs.

    Returns
    -------
    idx : (m, k) int64
        Indices, highest first; unused slots repeat the highest.
    count : (m,) int64
        Maxima kept per row (at least 1).
    """
    m = r.shape[0]
    out = np.empty((m, k), np.int64)
    count = np.empty(m, np.int64)
    vals = np.empty(k)
    for i in range(m):
        n_found = 0
        for j in range(lo[i], hi[i] + 1):
            v = r[i, j]
            if j > lo[i] and r[i, j - 1] > v:
                continue
            if j < hi[i] and r[i, j + 1] >= v:
                continue
            if n_found < k:
                p = n_found
                n_found += 1
            elif v > vals[k - 1]:
                p = k - 1
            else:
                continue
            while p > 0 and vals[p - 1] < v:
                vals[p] = vals[p - 1]
                out[i, p] = out[i, p - 1]
                p -= 1
            vals[p] = v
            out[i, p] = j
        if n_found == 0:  # flat row: take the window's first sample
            out[i, 0] = lo[i]
            n_found = 1
        elif vals[0] > 0:
            c = 1
            while c < n_found and vals[c] >= frac * vals[0]:
                c += 1
            n_found = c
        else:
            n_found = 1
        count[i] = n_found
        for q in range(n_found, k):
            out[i, q] = out[i, 0]
    return out, count


#: Half-width (samples) of the windowed-sinc interpolator of :func:`sinc_refine`.
SINC_HALF = 16


_D = np.arange(-SINC_HALF + 1, SINC_HALF + 1)
#: cos and sin of the window's angular step times each tap offset, for angle addition
_WC1 = np.cos(np.pi / SINC_HALF * _D)
_WS1 = np.sin(np.pi / SINC_HALF * _D)
_WC2 = np.cos(2 * np.pi / SINC_HALF * _D)
_WS2 = np.sin(2 * np.pi / SINC_HALF * _D)


@njit(cache=True, fastmath=True)
def _sinc_derivs(row, x, half):
    """r(x), r'(x), r''(x) of a sampled correlation row at fractional index x, interpolated
    with a Blackman-windowed sinc of ``half`` samples each side (derivatives in samples).

    The sines of π(x − j) alternate in sign with j and the window's cosines follow from angle
    addition with tabulated tap offsets, so an evaluation needs six transcendental calls.
    """
    j0 = int(math.floor(x))
    f = x - j0
    pk = math.pi / half
    sf = math.sin(math.pi * f)
    cf = math.cos(math.pi * f)
    c1f = math.cos(pk * f)
    s1f = math.sin(pk * f)
    c2f = math.cos(2.0 * pk * f)
    s2f = math.sin(2.0 * pk * f)
    r = 0.0
    r1 = 0.0
    r2 = 0.0
    for q in range(2 * half):
        d = q - half + 1  # j = j0 + d, u = f − d
        j = j0 + d
        if j < 0 or j >= row.shape[0]:
            continue
        u = f - d
        pu = math.pi * u
        sign = 1.0 if d % 2 == 0 else -1.0
        sn = sign * sf  # sin(π(f − d))
        cs = sign * cf
        if abs(u) < 1e-6:
            sv = 1.0 - pu * pu / 6.0
            s1 = -math.pi * pu / 3.0
            s2 = -math.pi * math.pi / 3.0
        else:
            sv = sn / pu
            s1 = cs / u - sn / (pu * u)
            s2 = -math.pi * sn / u - 2.0 * cs / (u * u) + 2.0 * sn / (pu * u * u)
        # cos(pk(f − d)) = cos(pk f) cos(pk d) + sin(pk f) sin(pk d)
        c1 = c1f * _WC1[q] + s1f * _WS1[q]
        sn1 = s1f * _WC1[q] - c1f * _WS1[q]
        c2 = c2f * _WC2[q] + s2f * _WS2[q]
        sn2 = s2f * _WC2[q] - c2f * _WS2[q]
        w = 0.42 + 0.5 * c1 + 0.08 * c2
        w1 = -0.5 * pk * sn1 - 0.16 * pk * sn2
        w2 = -0.5 * pk * pk * c1 - 0.32 * pk * pk * c2
        v = row[j]
        r += v * sv * w
        r1 += v * (s1 * w + sv * w1)
        r2 += v * (s2 * w + 2.0 * s1 * w1 + sv * w2)
    return r, r1, r2


@njit(cache=True)
def sinc_refine(r, rows, x0, lo, hi, n_iter, tol):
    """Newton search for the maximum of windowed-sinc interpolated correlation rows.

    Parameters
    ----------
    r : (m_rows, n_lags) float
        Sampled correlation rows.
    rows : (m,) int64
        Row of each search.
    x0, lo, hi : (m,) float64
        Start and bounds, fractional sample indices into the rows.
    n_iter : int
        Most Newton steps.
    tol : float
        Steps shorter than this (samples) end the search.

    Returns
    -------
    x, rv, r2v : (m,) float64
        Index of the maximum, the interpolated value and second derivative (per sample²).
    """
    m = x0.shape[0]
    xs = np.empty(m)
    rv = np.empty(m)
    r2v = np.empty(m)
    for i in range(m):
        row = r[rows[i]]
        t = x0[i]
        v, v1, v2 = _sinc_derivs(row, t, SINC_HALF)
        for _ in range(n_iter):
            if v2 >= 0.0:
                break
            step = -v1 / v2
            tn = min(max(t + step, lo[i]), hi[i])
            vn, v1n, v2n = _sinc_derivs(row, tn, SINC_HALF)
            if vn < v:
                break
            t, v, v1, v2 = tn, vn, v1n, v2n
            if abs(step) < tol:
                break
        xs[i] = t
        rv[i] = v
        r2v[i] = v2
    return xs, rv, r2v


@njit(cache=True)
def fill_transposed(frames, buf, n):
    """buf[s, c, :n] = frames[s, :, c] and buf[s, c, n:] = 0, in cache-sized tiles.

    Parameters
    ----------
    frames : (S, n, C) float array
        Snapshots, time along axis 1.
    buf : (S, C, N) float array
        Transform input, N >= n.
    n : int
        Samples per snapshot.
    """
    S, _, C = frames.shape
    N = buf.shape[2]
    tile = 64
    for s in range(S):
        for t0 in range(0, n, tile):
            t1 = min(n, t0 + tile)
            for c in range(C):
                for t in range(t0, t1):
                    buf[s, c, t] = frames[s, t, c]
        for c in range(C):
            for t in range(n, N):
                buf[s, c, t] = 0.0


@njit(cache=True)
def cross_band(X, ref, out, energy):
    """Cross-spectra against the reference and band energies in one pass.

    Parameters
    ----------
    X : (S, C, nb) complex array
        Band bins of every channel's spectrum.
    ref : int
        Reference channel.
    out : (S·C, nb) complex array
        Receives X[s, c] · conj(X[s, ref]) in row s·C + c.
    energy : (S, C) float64 array
        Receives Σ_k |X[s, c, k]|².
    """
    S, C, nb = X.shape
    for s in range(S):
        for c in range(C):
            row = s * C + c
            acc = 0.0
            for k in range(nb):
                x = X[s, c, k]
                r = X[s, ref, k]
                out[row, k] = x * np.conj(r)
                acc += float(x.real) * float(x.real) + float(x.imag) * float(x.imag)
            energy[s, c] = acc


@njit(cache=True)
def distinct_peaks(tau, height, ok, k, min_sep):
    """The ``k`` highest peaks of each row that lie at least ``min_sep`` from every higher
    kept peak (a refined correlation's maxima, several candidates of which may converge on
    one lag, and whose carrier cycles around a peak are not other sources).

    Parameters
    ----------
    tau, height : (m, c) float64
        Lag (s) and height of each candidate of each row.
    ok : (m, c) bool
        Usable candidates.
    k : int
        Most peaks kept per row.
    min_sep : float
        Smallest distance (s) between two kept peaks of a row.

    Returns
    -------
    (m, k) int64
        Column of each kept peak, highest first; −1 in unused slots.
    """
    m, c = tau.shape
    out = np.full((m, k), -1, np.int64)
    taken = np.zeros(c, np.bool_)
    for i in range(m):
        taken[:] = False
        n_kept = 0
        while n_kept < k:
            best = -1
            for j in range(c):
                if ok[i, j] and not taken[j] and (best < 0 or height[i, j] > height[i, best]
                                                  or (height[i, j] == height[i, best]
                                                      and tau[i, j] < tau[i, best])):
                    best = j
            if best < 0:
                break
            taken[best] = True
            far = True
            for q in range(n_kept):
                if abs(tau[i, best] - tau[i, out[i, q]]) < min_sep:
                    far = False
                    break
            if far:
                out[i, n_kept] = best
                n_kept += 1
    return out
