"""Numba kernels of incoherent integration (thesis eq. 2.22): |y|² and sliding sums of beam
power taken straight from the complex beams, so no (S, F, B) power array is ever stored.
``nogil`` so the ``integrate`` stage can run them on several threads (one range of cells each).
"""

from __future__ import annotations

import numpy as np
from numba import njit, uint64


@njit(cache=True, nogil=True)
def abs2(y: np.ndarray, out: np.ndarray) -> None:
    """``out = |y|²`` elementwise for flat complex64 ``y`` into flat float32 ``out``."""
    for i in range(y.shape[0]):
        v = y[i]
        out[i] = v.real * v.real + v.imag * v.imag


@njit(cache=True, nogil=True)
def power_sums(head: np.ndarray, y: np.ndarray, n: int, step: int, lo: int, hi: int,
               out: np.ndarray, acc: np.ndarray) -> None:
    """Sums of ``n`` consecutive snapshot powers every ``step`` snapshots (thesis eq. 2.22),
    straight from the complex beams, for the columns ``lo:hi``.

    The snapshots are the rows of ``head`` (h, M) float32 — powers carried over from the
    previous block — followed by ``|y|²`` of the rows of ``y`` (T, M) complex. ``out`` (K, M)
    receives window k = rows k·step .. k·step + n − 1; ``acc`` (M,) float64 is scratch (the
    sums accumulate in float64). Blockwise (step >= n) sums each window afresh; a sliding
    window (step < n) adds the snapshots that come in and drops those that leave.
    """
    h = head.shape[0]
    k_out = out.shape[0]
    c0, c1 = uint64(lo), uint64(hi)
    for k in range(k_out):
        a = k * step
        if k == 0 or step >= n:
            add0, add1, sub0, sub1 = a, a + n, 0, 0
            for i in range(c0, c1):
                acc[i] = 0.0
        else:
            add0, add1, sub0, sub1 = a + n - step, a + n, a - step, a
        for r in range(add0, add1):
            if r < h:
                row = head[r]
                for i in range(c0, c1):
                    acc[i] += row[i]
            else:
                yr = y[r - h]
                for i in range(c0, c1):
                    v = yr[i]
                    acc[i] += v.real * v.real + v.imag * v.imag
        for r in range(sub0, sub1):
            if r < h:
                row = head[r]
                for i in range(c0, c1):
                    acc[i] -= row[i]
            else:
                yr = y[r - h]
                for i in range(c0, c1):
                    v = yr[i]
                    acc[i] -= v.real * v.real + v.imag * v.imag
        o = out[k]
        for i in range(c0, c1):
            o[i] = acc[i]
