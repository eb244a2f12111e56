"""CLEAN of azimuth × elevation band power: several sources' directions below the sidelobes of
the strongest (``bearings`` key ``clean`` on ``cbf_azel`` beams).

A compact array's conventional beams are wide and their sidelobes high: the band power of a
plane wave from d_k over the grid of ``cbf_azel`` (its eq. (2), unshaded) is, with a flat
source spectrum over the band [f_lo, f_hi] and N hydrophones::

    A_k B_k(d),  B_k(d) = [N + 2 Σ_{m<n} r(Δ_mn(d) − Δ_mn(d_k))] / N²,
    r(u) = [sin 2π f_hi u − sin 2π f_lo u] / [2π u (f_hi − f_lo)]   (r(0) = 1)          (K1)

(``Δ_mn(d) = (r_m − r_n)·k(d)/c``; B_k(d_k) = 1 and its floor is the autopower share 1/N),
so the sidelobes of a near vessel stand above the main lobe of a farther one and a peak
picker takes them for sources. The integrated power of a scan is modelled as noise plus
sources, ``P(d) ≈ P_n + Σ_k A_k B_k(d)``, and the directions are found greedily: the largest
residual of the current non-negative least-squares fit (``scipy.optimize.nnls`` on the
columns [1, B_1, …]), at least ``min_separation`` from every direction kept, becomes a new
component, kept while its power over the noise, ``A_k / P_n``, is at least ``threshold_db``
and it lies within ``dynamic_db`` of the strongest component. Each kept direction is then
refined on its own map ``q_k = P − P_n − Σ_{j≠k} A_j B_j`` (the other sources removed; the
sub-grid peak of :func:`arrayproc.dsp.peaks2d.pick_peaks_2d`), and the powers refitted;
twice (:data:`REFINE_PASSES`), the second with the others' refined patterns.

The flat spectrum is an assumption: a coloured source spectrum changes r(u) (the mainlobe
widens towards the low frequencies), which leaves a residual near a strong source; the
``min_separation`` of the search keeps it from becoming a component.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import nnls

from arrayproc.dsp.peaks2d import pick_peaks_2d

__all__ = ["band_correlation", "AzelPattern", "clean_peaks", "NOISE_FLOOR"]

#: refinement passes of the directions (each with the others' refined patterns removed)
REFINE_PASSES = 2

#: the fitted noise power's floor, a fraction of the scan's largest power (60 dB down)
NOISE_FLOOR = 1e-6


def band_correlation(u: np.ndarray, f_lo: float, f_hi: float) -> np.ndarray:
    """r(u) of eq. (K1): the mean of cos 2πfu over f in [f_lo, f_hi] (u in s)."""
    u = np.asarray(u, float)
    w = 2.0 * math.pi * u
    safe = np.where(np.abs(w) < 1e-12, 1.0, w)
    r = (np.sin(f_hi * w) - np.sin(f_lo * w)) / (safe * (f_hi - f_lo))
    return np.where(np.abs(w) < 1e-12, 1.0, r)


def _unit(az_deg: np.ndarray, el_deg: np.ndarray) -> np.ndarray:
    """Body-frame unit vectors (…, 3) towards azimuths (relative to the body x axis) and
    elevations (deg, up), z down: (cos e cos β, cos e sin β, −sin e)."""
    a, e = np.deg2rad(az_deg), np.deg2rad(el_deg)
    return np.stack([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), -np.sin(e)], -1)


class AzelPattern:
    """Patterns B_k (eq. K1) of one array and band on one elevation-major direction grid.

    Parameters
    ----------
    positions : (N, 3) array_like
        Element positions, body frame (m).
    sound_speed : float
        m/s.
    az, el : ndarray
        Grid azimuths (true, deg) and elevations (deg).
    f_lo, f_hi : float
        The band (Hz).
    """

    def __init__(self, positions: np.ndarray, sound_speed: float, az: np.ndarray,
                 el: np.ndarray, f_lo: float, f_hi: float) -> None:
        p = np.asarray(positions, float)
        self.n = p.shape[0]
        m, n = np.triu_indices(self.n, 1)
        self.base = (p[m] - p[n]) / float(sound_speed)  # (P, 3) s
        e, a = np.meshgrid(el, az, indexing="ij")
        self.az, self.el = a.ravel(), e.ravel()
        self.f_lo, self.f_hi = float(f_lo), float(f_hi)
        self._heading: float | None = None

    def _grid(self, heading: float) -> None:
        if heading != self._heading:
            self._heading = heading
            self.k = _unit(self.az - heading, self.el)  # (D, 3)
            self.lags = self.k @ self.base.T              # (D, P)

    def pattern(self, az: float, el: float, heading: float) -> np.ndarray:
        """B (D,) of a plane wave from true azimuth ``az``, elevation ``el`` (deg)."""
        self._grid(heading)
        lag0 = _unit(np.array(az - heading), np.array(el)) @ self.base.T  # (P,)
        r = band_correlation(self.lags - lag0, self.f_lo, self.f_hi)
        return (self.n + 2.0 * r.sum(axis=1)) / self.n**2

    def cos_sep(self, az: float, el: float, heading: float) -> np.ndarray:
        """cos of the angle (D,) between every grid direction and (az, el)."""
        self._grid(heading)
        return self.k @ _unit(np.array(az - heading), np.array(el))


def _fit(p: np.ndarray, cols: list[np.ndarray]) -> np.ndarray:
    """Non-negative coefficients [P_n, A_1, …] of p ≈ P_n + Σ A_k B_k."""
    m = np.stack([np.ones_like(p)] + cols, 1)
    scale = float(p.max())
    g, h = m.T @ m, m.T @ (p / scale)
    c = np.zeros(m.shape[1])
    on = np.ones(m.shape[1], bool)
    while on.any():  # the normal equations on the free set; a negative coefficient leaves it
        sol = np.linalg.lstsq(g[np.ix_(on, on)], h[on], rcond=None)[0]
        if np.all(sol >= 0):
            c[on] = sol
            break
        idx = np.flatnonzero(on)
        on[idx[int(np.argmin(sol))]] = False
    if on.any() and np.any(h - g @ c > 1e-9 * max(float(np.abs(h).max()), 1e-300)) \
            and not on.all():
        c = nnls(m, p / scale)[0]  # the free set was not optimal: the full active-set solver
    c = c * scale
    c[0] = max(c[0], NOISE_FLOOR * scale)  # a noise-free fit: the floor of the SNRs
    return c


def clean_peaks(power: np.ndarray, pat: AzelPattern, heading: float, az: np.ndarray,
                el: np.ndarray, wrap: bool, threshold_db: float, dynamic_db: float,
                min_sep: float, max_peaks: int
                ) -> tuple[list[tuple[float, float, float, float, float]], float]:
    """The CLEAN components of one scan's band power (module doc).

    Parameters
    ----------
    power : (D,) ndarray
        Linear band power on the elevation-major grid.
    pat : AzelPattern
        Patterns of the array and band.
    heading : float
        Array heading of the scan (deg).
    az, el : ndarray
        The grid axes (deg); ``wrap`` whether the azimuths close the circle.
    threshold_db, dynamic_db, min_sep : float
        A component is kept while 10 log10(A_k / P_n) ≥ ``threshold_db`` and A_k is within
        ``dynamic_db`` of the strongest; new components at least ``min_sep`` deg from kept
        ones.
    max_peaks : int
        Most components.

    Returns
    -------
    list of (azimuth, elevation, A_k, curvature_az, level_db), float
        Components strongest first (``curvature_az`` dB/deg² of the refined peak, for
        :func:`arrayproc.dsp.peaks2d.curvature_sigma`; ``level_db`` that of ``q_k``), and
        the noise power P_n.
    """
    p = np.asarray(power, float)
    dirs: list[tuple[float, float]] = []
    cols: list[np.ndarray] = []
    coef = _fit(p, cols)
    cos_min = math.cos(math.radians(min_sep))
    for _ in range(max_peaks):
        res = p - coef[0] - sum((c * b for c, b in zip(coef[1:], cols, strict=True)),
                                np.zeros_like(p))
        for a, e in dirs:
            res[pat.cos_sep(a, e, heading) > cos_min] = -np.inf
        i = int(np.argmax(res))
        if not np.isfinite(res[i]) or res[i] <= 0:
            break
        cand = (float(pat.az[i]), float(pat.el[i]))
        b_new = pat.pattern(*cand, heading)
        trial = _fit(p, cols + [b_new])
        a_new, a_max = trial[-1], float(np.max(trial[1:]))
        if trial[0] <= 0 or a_new <= 0 or 10 * math.log10(a_new / trial[0]) < threshold_db \
                or a_new < a_max * 10 ** (-dynamic_db / 10):
            break
        dirs.append(cand)
        cols.append(b_new)
        coef = trial
    out: list[tuple[float, float, float, float, float]] = []
    for _ in range(REFINE_PASSES):  # each direction on its own map, the others removed
        if not dirs:
            break
        out = _refine(p, pat, heading, az, el, wrap, dirs, coef, cols, cos_min)
        dirs = [(o[0], o[1]) for o in out]
        cols = [pat.pattern(a, e, heading) for a, e in dirs]
        coef = _fit(p, cols)
    out = [(a, e, float(coef[1 + k]), c, lev) for k, (a, e, _, c, lev) in enumerate(out)]
    out = [o for o in out if o[2] > 0]
    out.sort(key=lambda o: -o[2])
    return out, float(coef[0])


def _refine(p: np.ndarray, pat: AzelPattern, heading: float, az: np.ndarray, el: np.ndarray,
            wrap: bool, dirs: list[tuple[float, float]], coef: np.ndarray,
            cols: list[np.ndarray], cos_min: float
            ) -> list[tuple[float, float, float, float, float]]:
    """Each direction's sub-grid peak on ``q_k = P − P_n − Σ_{j≠k} A_j B_j`` within the
    search separation of it: (azimuth, elevation, 0, curvature_az, level_db of q_k)."""
    out = []
    n_el, n_az = el.size, az.size
    for k in range(len(dirs)):
        q = p - coef[0] - sum((coef[1 + j] * cols[j] for j in range(len(dirs)) if j != k),
                              np.zeros_like(p))
        floor = max(float(coef[1 + k]) * 1e-3, 1e-300)
        qdb = 10 * np.log10(np.maximum(q, floor)).reshape(n_el, n_az)
        qdb[(pat.cos_sep(*dirs[k], heading) < cos_min).reshape(n_el, n_az)] = -np.inf
        pk = pick_peaks_2d(qdb, az, el, -np.inf, 0.0, 1, wrap)
        if pk and all(math.isfinite(v) for v in pk[0]):
            out.append((pk[0][0], pk[0][1], 0.0, pk[0][3], pk[0][2]))
        else:
            out.append((dirs[k][0], dirs[k][1], 0.0, -1.0, float(np.max(qdb))))
    return out
