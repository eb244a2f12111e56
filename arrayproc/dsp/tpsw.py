"""Two-pass split-window (TPSW) background estimate, the usual LOFAR-gram normalisation.

For each bin i of a spectrum the split window averages the bins with ``gap < |j − i| <=
half`` (a window of ``2·half + 1`` bins without its centre ``2·gap + 1``), clipped at the
spectrum's ends. Pass 1 gives a first mean m1; bins above ``clip · m1`` (lines) are replaced
by m1; pass 2 averages the clipped spectrum with the same split window. The normalised
spectrum is ``x / background``: about 1 in noise, the line-to-background ratio on lines.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def _split_mean_row(x: np.ndarray, half: int, gap: int, out: np.ndarray) -> None:
    n = x.shape[0]
    cs = np.zeros(n + 1)
    for i in range(n):
        cs[i + 1] = cs[i] + x[i]
    for i in range(n):
        a0, a1 = max(0, i - half), max(0, i - gap)      # [a0, a1): left part
        b0, b1 = min(n, i + gap + 1), min(n, i + half + 1)  # [b0, b1): right part
        cnt = (a1 - a0) + (b1 - b0)
        s = (cs[a1] - cs[a0]) + (cs[b1] - cs[b0])
        out[i] = s / cnt if cnt > 0 else x[i]


@njit(cache=True, nogil=True)
def tpsw_rows(x: np.ndarray, half: int, gap: int, clip: float, out: np.ndarray) -> None:
    """TPSW background of each row of ``x`` (R, F) into ``out`` (R, F) (float64 sums)."""
    r, n = x.shape
    m1 = np.empty(n)
    xc = np.empty(n)
    row = np.empty(n)
    for k in range(r):
        for i in range(n):
            row[i] = x[k, i]
        _split_mean_row(row, half, gap, m1)
        for i in range(n):
            xc[i] = m1[i] if row[i] > clip * m1[i] else row[i]
        _split_mean_row(xc, half, gap, m1)
        for i in range(n):
            out[k, i] = m1[i]


def tpsw(x: np.ndarray, half: int = 32, gap: int = 3, clip: float = 2.0) -> np.ndarray:
    """TPSW background of ``x`` (..., F) along its last axis (same shape, float64)."""
    x = np.asarray(x)
    flat = np.ascontiguousarray(x.reshape(-1, x.shape[-1]), dtype=np.float64)
    out = np.empty_like(flat)
    tpsw_rows(flat, int(half), int(gap), float(clip), out)
    return out.reshape(x.shape)


def tpsw_db(x: np.ndarray, background: np.ndarray) -> np.ndarray:
    """Level of ``x`` over its TPSW ``background`` in dB, ``10·log10(x / background)`` (both
    floored at 1e-300 so empty bins stay finite): 0 dB in noise, the line-to-background ratio
    on lines; the normalisation of the LOFAR display, the bearings' lines and line contacts."""
    return 10 * np.log10(np.maximum(x, 1e-300) / np.maximum(background, 1e-300))
