"""CFAR detection on square-law matched-filter output and clustering of the detected cells.

Closed forms for a square-law detector in exponential (Rayleigh-envelope) noise, threshold
``alpha * estimate`` with ``estimate`` the noise estimate from N training cells:

- CA (mean of N cells):       pfa = (1 + alpha/N)^(-N)
- GO / SO (larger / smaller of the means of two halves of n = N/2 cells each), a = alpha/n:
  pfa_SO = 2 sum_{k=0}^{n-1} C(n-1+k, k) (2 + a)^(-(n+k)),
  pfa_GO = 2 (1 + a)^(-n) - pfa_SO
- OS (k-th smallest of N cells): pfa = prod_{i=0}^{k-1} (N - i) / (N - i + alpha)
- Swerling-1 target of mean SNR S in a CA cell: pd = (1 + alpha / (N (1 + S)))^(-N)

(Gandhi and Kassam, IEEE TAES 24(4), 1988; Rohling, IEEE TAES 19(4), 1983.) The thresholds are
solved for ``pfa`` with scipy's brentq. The detector itself is
:func:`arrayproc.stages.active._kernels.cfar_plane`; adjacent detected cells (8-neighbourhood
in Doppler x range) become one contact with its peak interpolated by a parabola on the
log-power of the peak cell and its neighbours (Gaussian interpolation).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.optimize import brentq
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.special import gammaln

from arrayproc.errors import ConfigError

from . import _kernels as K

METHODS = {"ca": K.MODE_CA, "go": K.MODE_GO, "so": K.MODE_SO, "os": K.MODE_OS}


def pfa_ca(alpha: float, n: int) -> float:
    """False-alarm probability of CA-CFAR, threshold alpha x mean of n cells."""
    return float((1.0 + alpha / n) ** (-n))


def _so_sum(a: float, n: int) -> float:
    k = np.arange(n)
    logc = gammaln(n + k) - gammaln(k + 1) - gammaln(n)
    return float(2.0 * np.sum(np.exp(logc - (n + k) * np.log(2.0 + a))))


def pfa_so(alpha: float, n: int) -> float:
    """False-alarm probability of SO-CFAR: alpha x the smaller of the means of two halves of
    n cells each."""
    return _so_sum(alpha / n, n)


def pfa_go(alpha: float, n: int) -> float:
    """False-alarm probability of GO-CFAR: alpha x the larger of the means of two halves of
    n cells each."""
    a = alpha / n
    return float(2.0 * (1.0 + a) ** (-n) - _so_sum(a, n))


def pfa_os(alpha: float, n: int, k: int) -> float:
    """False-alarm probability of OS-CFAR: alpha x the k-th smallest of n cells."""
    i = np.arange(k)
    return float(np.exp(np.sum(np.log(n - i) - np.log(n - i + alpha))))


def pd_ca_swerling1(alpha: float, n: int, snr: float | np.ndarray) -> np.ndarray:
    """Detection probability of CA-CFAR for a Swerling-1 target of mean SNR ``snr`` (linear)."""
    return (1.0 + alpha / (n * (1.0 + np.asarray(snr, float)))) ** (-n)


def _solve(f, pfa: float) -> float:
    g = lambda a: np.log(f(a)) - np.log(pfa)  # noqa: E731
    hi = 1.0
    while g(hi) > 0:
        hi *= 2.0
        if hi > 1e12:  # pragma: no cover - pfa far below what any window can give
            raise ConfigError(f"cfar: pfa {pfa:g} unreachable with this training window")
    return float(brentq(g, 0.0, hi, xtol=1e-12, rtol=1e-12))


@lru_cache(maxsize=256)
def alpha_ca(pfa: float, n: int) -> float:
    """CA threshold multiplier (of the mean) for ``pfa``: n (pfa^(-1/n) - 1)."""
    return float(n * (pfa ** (-1.0 / n) - 1.0))


@lru_cache(maxsize=256)
def alpha_go(pfa: float, n: int) -> float:
    """GO threshold multiplier (of the larger half mean, halves of n cells) for ``pfa``."""
    return _solve(lambda a: pfa_go(a, n), pfa)


@lru_cache(maxsize=256)
def alpha_so(pfa: float, n: int) -> float:
    """SO threshold multiplier (of the smaller half mean, halves of n cells) for ``pfa``."""
    return _solve(lambda a: pfa_so(a, n), pfa)


@lru_cache(maxsize=4096)
def alpha_os(pfa: float, n: int, k: int) -> float:
    """OS threshold multiplier (of the k-th smallest of n cells) for ``pfa``."""
    return _solve(lambda a: pfa_os(a, n, k), pfa)


def os_rank(n: int, q: float) -> int:
    """Rank k used by OS-CFAR with n training cells: round(q n), at least 1."""
    return int(min(n, max(1, round(q * n))))


@dataclass(frozen=True)
class CfarConfig:
    """A CFAR design.

    Parameters
    ----------
    method : {"ca", "go", "so", "os"}
    pfa : float
        Design false-alarm probability per cell.
    guard, train : (int, int)
        Guard and training cells on each side, in (range, Doppler) cells; Doppler 0, 0 gives a
        1-D CFAR along range.
    os_quantile : float
        OS rank as a fraction of the training cells (k = round(q N)).
    """

    method: str = "ca"
    pfa: float = 1e-6
    guard: tuple[int, int] = (4, 0)
    train: tuple[int, int] = (16, 0)
    os_quantile: float = 0.75

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise ConfigError(f"cfar: key 'method' must be one of {', '.join(METHODS)}, "
                              f"got {self.method!r}")
        if not 0.0 < self.pfa < 0.5:
            raise ConfigError(f"cfar: key 'pfa' must lie in (0, 0.5), got {self.pfa}")
        if min(self.guard) < 0 or min(self.train) < 0 or self.train[0] < 1:
            raise ConfigError("cfar: keys 'guard' and 'train' must be >= 0 cells (train in "
                              "range >= 1)")
        if not 0.0 < self.os_quantile <= 1.0:
            raise ConfigError(f"cfar: key 'os_quantile' must lie in (0, 1], "
                              f"got {self.os_quantile}")

    @property
    def n_max(self) -> int:
        (gr, gd), (tr, td) = self.guard, self.train
        return (2 * (gd + td) + 1) * (2 * (gr + tr) + 1) - (2 * gd + 1) * (2 * gr + 1)

    @property
    def half_n(self) -> int:
        (gr, gd), (tr, td) = self.guard, self.train
        return (2 * (gd + td) + 1) * (gr + tr) - (2 * gd + 1) * gr

    def tables(self) -> tuple[np.ndarray, float, np.ndarray]:
        """(alpha by training count N, alpha of GO/SO interior cells, OS rank by N)."""
        nmax = self.n_max
        alpha_n = np.full(nmax + 1, np.inf)
        ks = np.ones(nmax + 1, np.int64)
        for n in range(1, nmax + 1):
            if self.method == "os":
                ks[n] = os_rank(n, self.os_quantile)
                alpha_n[n] = alpha_os(self.pfa, n, int(ks[n]))
            else:
                alpha_n[n] = alpha_ca(self.pfa, n)
        half = 0.0
        if self.method == "go":
            half = alpha_go(self.pfa, self.half_n)
        elif self.method == "so":
            half = alpha_so(self.pfa, self.half_n)
        return alpha_n, half, ks


@dataclass
class Detections:
    """Cells over threshold of one plane: Doppler row, range column, power, noise estimate."""

    rows: np.ndarray
    cols: np.ndarray
    power: np.ndarray
    noise: np.ndarray


def detect(p: np.ndarray, cfg: CfarConfig, r0: int = 0, r1: int | None = None,
           tables: tuple | None = None) -> Detections:
    """Run the CFAR over a square-law plane p (D, R) (float32), testing columns r0 ... r1-1.

    Parameters
    ----------
    p : (D, R) ndarray
        |matched filter|^2, Doppler rows by range columns.
    cfg : CfarConfig
    r0, r1 : int
        Range columns tested (training cells may lie outside).
    tables : tuple, optional
        ``cfg.tables()`` when already computed.

    Returns
    -------
    Detections
    """
    p = np.ascontiguousarray(p, np.float32)
    if r1 is None:
        r1 = p.shape[1]
    a_n, a_half, ks = tables if tables is not None else cfg.tables()
    (gr, gd), (tr, td) = cfg.guard, cfg.train
    cap = 256
    while True:
        rows = np.empty(cap, np.int64)
        cols = np.empty(cap, np.int64)
        vals = np.empty(cap, np.float64)
        noise = np.empty(cap, np.float64)
        n = K.cfar_plane(p, gd, td, gr, tr, METHODS[cfg.method], a_n, a_half, cfg.half_n, ks,
                         int(r0), int(r1), rows, cols, vals, noise)
        if n >= 0:
            return Detections(rows[:n], cols[:n], vals[:n], noise[:n])
        cap = -n


@dataclass
class Cluster:
    """One contact's peak on a plane: fractional Doppler row and range column, peak power and
    the noise estimate there (linear), number of cells."""

    row: float
    col: float
    peak: float
    noise: float
    cells: int
    row_int: int
    col_int: int


def _interp(lo: float, mid: float, hi: float) -> float:
    """Offset in (-0.5, 0.5) of the vertex of the parabola through ln of three powers."""
    if lo <= 0 or hi <= 0 or mid <= 0:
        return 0.0
    a, b, c = np.log(lo), np.log(mid), np.log(hi)
    den = a - 2 * b + c
    if den >= 0:
        return 0.0
    return float(np.clip(0.5 * (a - c) / den, -0.5, 0.5))


def cluster(det: Detections, p: np.ndarray) -> list[Cluster]:
    """Group adjacent detected cells (8-neighbourhood) and interpolate each group's peak.

    Parameters
    ----------
    det : Detections
        From :func:`detect` on ``p``.
    p : (D, R) ndarray
        The square-law plane (for the peak's neighbours).

    Returns
    -------
    list of Cluster, strongest first.
    """
    n = det.rows.size
    if n == 0:
        return []
    order = np.lexsort((det.rows, det.cols))
    r, c = det.rows[order], det.cols[order]
    # neighbours: sorted by column; a cell can only touch cells within one column
    ii, jj = [], []
    j0 = 0
    for i in range(n):
        while c[j0] < c[i] - 1:
            j0 += 1
        for j in range(j0, i):
            if abs(r[j] - r[i]) <= 1 and abs(c[j] - c[i]) <= 1:
                ii.append(i)
                jj.append(j)
    g = coo_matrix((np.ones(len(ii)), (ii, jj)), shape=(n, n))
    ncomp, lab = connected_components(g, directed=False)
    val = det.power[order]
    nse = det.noise[order]
    out = []
    nd, nr = p.shape
    for k in range(ncomp):
        idx = np.flatnonzero(lab == k)
        m = idx[np.argmax(val[idx])]
        d, x = int(r[m]), int(c[m])
        dr = _interp(p[d - 1, x], p[d, x], p[d + 1, x]) if 0 < d < nd - 1 else 0.0
        dc = _interp(p[d, x - 1], p[d, x], p[d, x + 1]) if 0 < x < nr - 1 else 0.0
        out.append(Cluster(d + dr, x + dc, float(val[m]), float(nse[m]), idx.size, d, x))
    out.sort(key=lambda cl: -cl.peak / max(cl.noise, 1e-300))
    return out
