"""Numba kernels of the adaptive and subspace beamformers: the Hermitian form a^H Q a of every
beam through the co-array lags of a line array, and the white-noise-gain-constrained loading
of MVDR (Cox, Zeskind & Owen 1987). ``nogil`` so the stages can split bins over threads.

Hand-written because neither numpy nor scipy evaluates a Hermitian form on a lag grid (it
turns F·C²·B work of the direct product into F·(C² + L·B)), nor solves the loading equation
per (bin, beam).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def lag_sums(q: np.ndarray, lag: np.ndarray, out: np.ndarray) -> None:
    """``out[f, l] = Σ_{m,n : lag[n] − lag[m] = l} q[f, m, n]`` for l = 0 … L − 1: the sums of
    the Hermitian matrices ``q`` (F, C, C) over element pairs of equal co-array lag (``lag``
    (C,) integer positions on the line's grid, ≥ 0). ``out`` (F, L) complex128."""
    nf, c = q.shape[0], q.shape[1]
    for f in range(nf):
        o = out[f]
        for i in range(o.shape[0]):
            o[i] = 0.0
        qf = q[f]
        for m in range(c):
            lm = lag[m]
            for n in range(c):
                d = lag[n] - lm
                if d >= 0:
                    o[d] += qf[m, n]


@njit(cache=True, nogil=True)
def lag_form(s: np.ndarray, psi: np.ndarray, out: np.ndarray) -> None:
    """``out[f, b] = Re Σ_l s_l e^{jψ l} = s_0 + 2 Re Σ_{l≥1} s[f, l] e^{j l psi[f, b]}``: the
    Hermitian form a^H Q a of a steering vector a_n = e^{jψ·lag_n} from the lag sums of Q
    (s_{−l} = s_l* for Hermitian Q). The phasor e^{jψl} is advanced by one complex product per
    lag (rounding grows ~l ulps: < 1e-13 relative for L < 1000)."""
    nf, nb = psi.shape
    nl = s.shape[1]
    for f in range(nf):
        sf = s[f]
        for b in range(nb):
            p = psi[f, b]
            cr, ci = math.cos(p), math.sin(p)
            zr, zi = cr, ci
            acc = 0.0
            for lag in range(1, nl):
                v = sf[lag]
                acc += v.real * zr - v.imag * zi
                zr, zi = zr * cr - zi * ci, zr * ci + zi * cr
            out[f, b] = sf[0].real + 2.0 * acc


@njit(cache=True, nogil=True)
def _sums(lam: np.ndarray, p: np.ndarray, delta: float) -> tuple[float, float, float]:
    """Σ p/(λ+δ), Σ p/(λ+δ)², Σ pλ/(λ+δ)² of one (bin, beam)."""
    s1 = 0.0
    s2 = 0.0
    s3 = 0.0
    for i in range(lam.shape[0]):
        g = 1.0 / (lam[i] + delta)
        s1 += p[i] * g
        s2 += p[i] * g * g
        s3 += p[i] * lam[i] * g * g
    return s1, s2, s3


@njit(cache=True, nogil=True)
def wng_loading(lam: np.ndarray, p: np.ndarray, delta0: np.ndarray, wng_min: float,
                output: bool, power: np.ndarray, delta: np.ndarray, wng: np.ndarray) -> None:
    """MVDR with the white-noise-gain constraint (Cox, Zeskind & Owen 1987): per bin f
    and beam b the smallest loading δ ≥ ``delta0[f]`` whose weights w = (R + δI)⁻¹a / a^H(R +
    δI)⁻¹a reach WNG = |w^H a|²/‖w‖² = (Σ p/(λ+δ))² / Σ p/(λ+δ)² ≥ ``wng_min`` (linear), with
    λ (F, C) the eigenvalues of R and p (F, B, C) = |u_i^H a|². The WNG grows monotonically
    with δ (towards ‖a‖² = C), so δ is bracketed by doubling and found by bisection in log δ
    (60 steps: relative error of δ < 1e-9). Writes ``power`` (F, B): the Capon estimate
    1/a^H(R+δI)⁻¹a, or with ``output`` the beam's output power w^H R w; ``delta`` and the
    reached ``wng`` (linear) per cell."""
    nf, nb, c = p.shape
    for f in range(nf):
        lf = lam[f]
        scale = 0.0
        for i in range(c):
            scale = max(scale, lf[i])
        scale = max(scale, 1e-300)
        for b in range(nb):
            pb = p[f, b]
            d = delta0[f]
            s1, s2, s3 = _sums(lf, pb, d)
            if s1 * s1 / s2 < wng_min:
                lo = d
                hi = max(d, 1e-12 * scale) * 2.0
                s1, s2, s3 = _sums(lf, pb, hi)
                while s1 * s1 / s2 < wng_min and hi < 1e30 * scale:
                    lo = hi
                    hi *= 4.0
                    s1, s2, s3 = _sums(lf, pb, hi)
                for _ in range(60):
                    mid = math.sqrt(max(lo, 1e-300 * scale) * hi)
                    t1, t2, _t3 = _sums(lf, pb, mid)
                    if t1 * t1 / t2 >= wng_min:
                        hi = mid
                    else:
                        lo = mid
                d = hi
                s1, s2, s3 = _sums(lf, pb, d)
            delta[f, b] = d
            wng[f, b] = s1 * s1 / s2
            power[f, b] = s3 / (s1 * s1) if output else 1.0 / s1
