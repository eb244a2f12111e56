"""CFAR: the numba kernel against a plain numpy reference (every method, 1-D and 2-D, edges),
the closed-form thresholds against Monte Carlo false-alarm rates on exponential noise (design
pfa 1e-3 ... 1e-6, CA and OS; GO, SO at 1e-3), Pd of a Swerling-1 target against the closed
form, and the clustering."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from arrayproc.stages.active import cfar as cf


def reference(p: np.ndarray, cfg: cf.CfarConfig) -> set[tuple[int, int]]:
    """Detected cells by the definitions, cell by cell."""
    (gr, gd), (tr, td) = cfg.guard, cfg.train
    a_n, a_half, ks = cfg.tables()
    nd, nr = p.shape
    hits = set()
    for d in range(nd):
        for r in range(nr):
            lead, lag, mid = [], [], []
            for i in range(max(0, d - gd - td), min(nd, d + gd + td + 1)):
                for j in range(max(0, r - gr - tr), min(nr, r + gr + tr + 1)):
                    if abs(i - d) <= gd and abs(j - r) <= gr:
                        continue
                    (lead if j < r else lag if j > r else mid).append(p[i, j])
            cells = np.array(lead + lag + mid)
            n = cells.size
            if n == 0:
                continue
            if cfg.method == "os":
                thr = a_n[n] * np.sort(cells)[ks[n] - 1]
            elif cfg.method in ("go", "so") and len(lead) == len(lag) == cfg.half_n:
                f = max if cfg.method == "go" else min
                thr = a_half * f(np.mean(lead), np.mean(lag))
            else:
                thr = a_n[n] * cells.mean()
            if p[d, r] > thr:
                hits.add((d, r))
    return hits


@pytest.mark.parametrize("method", ["ca", "go", "so", "os"])
@pytest.mark.parametrize("dims", [((3, 0), (6, 0)), ((2, 1), (4, 2))])
def test_kernel_matches_reference(method, dims):
    rng = np.random.default_rng(7)
    p = rng.exponential(1.0, (7, 90)).astype(np.float32)
    p[3, 40] = 60.0
    p[0, 2] = 40.0
    cfg = cf.CfarConfig(method, 1e-2, dims[0], dims[1])
    det = cf.detect(p, cfg)
    got = set(zip(det.rows.tolist(), det.cols.tolist()))
    assert got == reference(p, cfg)
    assert (3, 40) in got


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), method=st.sampled_from(["ca", "go", "so", "os"]),
       gr=st.integers(0, 3), tr=st.integers(1, 5), gd=st.integers(0, 1), td=st.integers(0, 2))
def test_kernel_property(seed, method, gr, tr, gd, td):
    """Any window, any plane: the kernel finds exactly the reference's cells."""
    rng = np.random.default_rng(seed)
    p = rng.exponential(1.0, (4, 30)).astype(np.float32)
    cfg = cf.CfarConfig(method, 5e-2, (gr, gd), (tr, td))
    det = cf.detect(p, cfg)
    assert set(zip(det.rows.tolist(), det.cols.tolist())) == reference(p, cfg)


def test_closed_forms_limits():
    """CA: alpha = N (pfa^(-1/N) - 1) reproduces pfa; OS with k = N equals 1/C(N+alpha, N)
    form; GO >= CA >= SO in pfa at the same multiplier."""
    for n in (8, 32):
        a = cf.alpha_ca(1e-4, n)
        assert np.isclose(cf.pfa_ca(a, n), 1e-4)
        assert cf.pfa_go(a, n // 2) < cf.pfa_ca(a, n) < cf.pfa_so(a, n // 2)
    assert np.isclose(cf.pfa_os(cf.alpha_os(1e-5, 24, 18), 24, 18), 1e-5)


def false_alarm_rate(method: str, pfa: float, n_cells: int, seed: int) -> tuple[float, int]:
    rng = np.random.default_rng(seed)
    cfg = cf.CfarConfig(method, pfa, (2, 0), (16, 0))
    rows = 200
    cols = n_cells // rows
    p = rng.standard_exponential((rows, cols), dtype=np.float32)
    det = cf.detect(p, cfg, r0=cfg.guard[0] + cfg.train[0],
                    r1=cols - cfg.guard[0] - cfg.train[0])
    tested = rows * (cols - 2 * (cfg.guard[0] + cfg.train[0]))
    return det.rows.size / tested, det.rows.size


@pytest.mark.parametrize("method,pfa", [("ca", 1e-3), ("ca", 1e-4), ("os", 1e-3),
                                        ("os", 1e-4), ("go", 1e-3), ("so", 1e-3)])
def test_false_alarm_rate(method, pfa):
    """Measured rate on exponential noise within a factor 2 of the design pfa."""
    n = int(60 / pfa)
    rate, count = false_alarm_rate(method, pfa, n, seed=11)
    assert 0.5 < rate / pfa < 2.0, (rate, count)


@pytest.mark.slow
@pytest.mark.parametrize("method,pfa", [("ca", 1e-5), ("ca", 1e-6), ("os", 1e-5),
                                        ("os", 1e-6)])
def test_false_alarm_rate_low(method, pfa):
    n = int(60 / pfa)
    rate, count = false_alarm_rate(method, pfa, n, seed=12)
    assert 0.5 < rate / pfa < 2.0, (rate, count)


def test_pd_swerling1_ca():
    """Pd of a Swerling-1 target against (1 + alpha/(N(1+S)))^-N, CA, pfa 1e-4, N = 32."""
    rng = np.random.default_rng(5)
    cfg = cf.CfarConfig("ca", 1e-4, (2, 0), (16, 0))
    a = cf.alpha_ca(1e-4, 32)
    for snr_db in (10.0, 15.0, 20.0):
        s = 10 ** (snr_db / 10)
        p = rng.standard_exponential((400, 2000), dtype=np.float32)
        cols = np.arange(40, 1960, 40)
        p[:, cols] = rng.exponential(1 + s, (400, cols.size))
        det = cf.detect(p, cfg)
        hit = np.isin(det.cols, cols).sum()
        pd = hit / (400 * cols.size)
        ref = float(cf.pd_ca_swerling1(a, 32, s))
        assert abs(pd - ref) < 0.02, (snr_db, pd, ref)


def test_cluster_interpolates_peak():
    """Adjacent cells form one cluster; the peak of a sampled parabola-in-log is recovered."""
    d0, r0 = 3.3, 50.6
    dd, rr = np.meshgrid(np.arange(8), np.arange(100), indexing="ij")
    p = (1e4 * np.exp(-0.5 * ((dd - d0) / 1.0) ** 2 - 0.5 * ((rr - r0) / 2.0) ** 2) + 1.0)
    p = p.astype(np.float32)
    p[6, 10] = 500.0  # a separate single-cell detection
    det = cf.detect(p, cf.CfarConfig("ca", 1e-3, (6, 0), (10, 0)))
    cl = cf.cluster(det, p)
    assert len(cl) == 2
    assert abs(cl[0].row - d0) < 0.05 and abs(cl[0].col - r0) < 0.05
    assert cl[1].row_int == 6 and cl[1].col_int == 10
