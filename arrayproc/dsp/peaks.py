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


def half_power_width(level_db: np.ndarray, axis: np.ndarray, i: int,
                     drop_db: float = 3.0103) -> float:
    """Full width (axis units) of the peak at index ``i`` of ``level_db`` where it has fallen
    ``drop_db`` below its sample value, linearly interpolated between samples on each side;
    a side that never falls that far (another lobe first, or the end of the axis) counts as
    the other side's half width (the whole axis span if neither falls)."""
    y = np.asarray(level_db, float)
    x = np.asarray(axis, float)
    top = y[i] - drop_db
    half = []
    for step in (-1, 1):
        j = i
        while 0 <= j + step < y.size and y[j + step] > top and y[j + step] <= y[j]:
            j += step
        k = j + step
        if 0 <= k < y.size and y[k] <= top:
            xc = x[j] + (x[k] - x[j]) * (y[j] - top) / (y[j] - y[k])
            half.append(abs(xc - x[i]))
    if not half:
        return float(abs(x[-1] - x[0]))
    return 2.0 * (sum(half) / len(half) if len(half) == 2 else half[0])


def pick_peaks(level_db: np.ndarray, axis: np.ndarray, floor_db: float, min_sep: float,
               max_peaks: int = 16, widths: float = 0.0) -> list[tuple[float, float, int]]:
    """Local maxima of ``level_db`` (n,) above ``floor_db``, strongest first, at least
    ``min_sep`` apart on ``axis`` (n,), each refined by a parabola through it and its two
    neighbours (in axis units and dB). With ``widths`` > 0 a weaker peak must also lie at
    least ``widths`` times the stronger one's own half-power width from it
    (:func:`half_power_width`): the separation follows the beam actually produced (narrow
    adaptive peaks, wide CBF ones) instead of a fixed angle. Returns ``[(axis_position,
    level_db, index), ...]``. End samples count as peaks only when above their single
    neighbour (no refinement)."""
    y = np.asarray(level_db, float)
    n = y.size
    if n == 0:
        return []
    left = np.r_[-np.inf, y[:-1]]
    right = np.r_[y[1:], -np.inf]
    cand = np.flatnonzero((y > left) & (y >= right) & (y > floor_db))
    cand = cand[np.argsort(-y[cand], kind="stable")]
    out: list[tuple[float, float, int]] = []
    wid: list[float] = []
    for i in cand:
        if 0 < i < n - 1:
            pos, lev = parabolic_vertex(axis[i - 1:i + 2], y[i - 1:i + 2])
        else:
            pos, lev = float(axis[i]), float(y[i])
        if any(abs(pos - p) < max(min_sep, widths * w) for (p, _, _), w in zip(out, wid)):
            continue
        out.append((pos, lev, int(i)))
        wid.append(half_power_width(y, axis, int(i)) if widths > 0 else 0.0)
        if len(out) >= max_peaks:
            break
    return out
