"""Peak picking with sub-sample interpolation, for bearings from BTR rows and LOFAR lines."""

from __future__ import annotations

import numpy as np


def parabolic_vertex(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """Vertex (x, y) of the parabola through three points (x0<x1<x2 need not be uniform)."""
    x0, x1, x2 = (float(v) for v in x)
    y0, y1, y2 = (float(v) for v in y)
    d = (x0 - x1) * (x0 - x2) * (x1 - x2)
    a = (x2 * (y1 - y0) + x1 * (y0 - y2) + x0 * (y2 - y1)) / d
    b = (x2 * x2 * (y0 - y1) + x1 * x1 * (y2 - y0) + x0 * x0 * (y1 - y2)) / d
    if a >= 0:  # not a maximum: keep the sample
        return x1, y1
    xv = -b / (2 * a)
    xv = min(max(xv, min(x0, x2)), max(x0, x2))
    c = y1 - a * x1 * x1 - b * x1
    return xv, a * xv * xv + b * xv + c


def pick_peaks(level_db: np.ndarray, axis: np.ndarray, floor_db: float, min_sep: float,
               max_peaks: int = 16) -> list[tuple[float, float, int]]:
    """Local maxima of ``level_db`` (n,) above ``floor_db``, strongest first, at least
    ``min_sep`` apart on ``axis`` (n,), each refined by a parabola through it and its two
    neighbours (in axis units and dB). Returns ``[(axis_position, level_db, index), ...]``.
    End samples count as peaks only when above their single neighbour (no refinement)."""
    y = np.asarray(level_db, float)
    n = y.size
    if n == 0:
        return []
    left = np.r_[-np.inf, y[:-1]]
    right = np.r_[y[1:], -np.inf]
    cand = np.flatnonzero((y > left) & (y >= right) & (y > floor_db))
    cand = cand[np.argsort(-y[cand], kind="stable")]
    out: list[tuple[float, float, int]] = []
    for i in cand:
        if 0 < i < n - 1:
            pos, lev = parabolic_vertex(axis[i - 1:i + 2], y[i - 1:i + 2])
        else:
            pos, lev = float(axis[i]), float(y[i])
        if any(abs(pos - p) < min_sep for p, _, _ in out):
            continue
        out.append((pos, lev, int(i)))
        if len(out) >= max_peaks:
            break
    return out
