"""Peak picking on an azimuth × elevation grid (the beams of ``cbf_azel``), with sub-cell
refinement and a curvature-based σ."""

from __future__ import annotations

import math

import numpy as np

from arrayproc.dsp.peaks import parabolic_vertex


def _neighbour_max(y: np.ndarray, wrap: bool) -> tuple[np.ndarray, np.ndarray]:
    """For each cell, the largest of its 8 neighbours that come before it in raster order and
    of those that come after (−inf off the grid; azimuth wraps when ``wrap``)."""
    n_el, n_az = y.shape
    pad = np.full((n_el + 2, n_az + 2), -np.inf)
    pad[1:-1, 1:-1] = y
    if wrap:
        pad[1:-1, 0], pad[1:-1, -1] = y[:, -1], y[:, 0]
    before = np.full(y.shape, -np.inf)
    after = np.full(y.shape, -np.inf)
    for de in (-1, 0, 1):
        for da in (-1, 0, 1):
            if de == 0 and da == 0:
                continue
            nb = pad[1 + de:1 + de + n_el, 1 + da:1 + da + n_az]
            tgt = before if (de, da) < (0, 0) else after
            np.maximum(tgt, nb, out=tgt)
    return before, after


def angle_between(az1: float, el1: float, az2: float, el2: float) -> float:
    """Great-circle angle (deg) between two directions given in azimuth/elevation (deg)."""
    a1, e1, a2, e2 = map(math.radians, (az1, el1, az2, el2))
    c = math.sin(e1) * math.sin(e2) + math.cos(e1) * math.cos(e2) * math.cos(a1 - a2)
    return math.degrees(math.acos(max(-1.0, min(1.0, c))))


def refine(y: np.ndarray, az: np.ndarray, el: np.ndarray, i: int, j: int,
           wrap: bool) -> tuple[float, float, float, float]:
    """Parabola through the peak cell (i, j) and its neighbours, separately along azimuth and
    elevation (dB). Returns ``(azimuth, elevation, level_db, curvature_az)`` with the
    curvature d²L/daz² in dB/deg² (0 where no parabola fits: an edge, a flat row)."""
    n_el, n_az = y.shape
    a_pos, lev, curv = float(az[j]), float(y[i, j]), 0.0
    if wrap or 0 < j < n_az - 1:
        jl, jr = (j - 1) % n_az, (j + 1) % n_az
        step = float(az[1] - az[0]) if n_az > 1 else 0.0
        xs = np.array([az[j] - step, az[j], az[j] + step])
        ys = np.array([y[i, jl], y[i, j], y[i, jr]])
        if np.all(np.isfinite(ys)) and step > 0:
            a_pos, lev = parabolic_vertex(xs, ys)
            curv = float(ys[0] - 2 * ys[1] + ys[2]) / step ** 2
    e_pos = float(el[i])
    if 0 < i < n_el - 1:
        e_pos, lev_e = parabolic_vertex(el[i - 1:i + 2], y[i - 1:i + 2, j])
        lev = max(lev, lev_e)
    return a_pos % 360.0, e_pos, lev, curv


def curvature_sigma(curv_db: float, snr_db: float, step: float) -> float:
    """σ (deg) of a peak's azimuth from the curvature of its log power: σ² = 1 / (2 · SNR ·
    |∂² ln P/∂az²|), SNR the peak over the noise level (linear), ∂² ln P = ln10/10 · the dB
    curvature; never below ``step``/√12, the spacing's quantisation (refinement not credited)."""
    floor = step / math.sqrt(12.0)
    k = abs(curv_db) * math.log(10.0) / 10.0
    snr = 10.0 ** (snr_db / 10.0)
    if k <= 0 or snr <= 0:
        return max(floor, step)
    return max(floor, 1.0 / math.sqrt(2.0 * snr * k))


def pick_peaks_2d(level_db: np.ndarray, az: np.ndarray, el: np.ndarray, floor_db: float,
                  min_sep: float, max_peaks: int = 16, wrap: bool = True
                  ) -> list[tuple[float, float, float, float]]:
    """Every local maximum of ``level_db`` (n_el, n_az) above ``floor_db`` (8-neighbourhood;
    ties go to the first cell in raster order, so a plateau such as a pole row gives one),
    strongest first, at least ``min_sep`` deg (great circle) from every stronger kept peak, at
    most ``max_peaks``. Returns ``[(azimuth, elevation, level_db, curvature_az), ...]``
    (:func:`refine`)."""
    y = np.asarray(level_db, float)
    before, after = _neighbour_max(y, wrap)
    cand = np.argwhere((y > before) & (y >= after) & (y > floor_db))
    order = np.argsort(-y[cand[:, 0], cand[:, 1]], kind="stable")
    out: list[tuple[float, float, float, float]] = []
    for i, j in cand[order]:
        a, e, lev, curv = refine(y, az, el, int(i), int(j), wrap)
        if any(angle_between(a, e, p[0], p[1]) < min_sep for p in out):
            continue
        out.append((a, e, lev, curv))
        if len(out) >= max_peaks:
            break
    return out
