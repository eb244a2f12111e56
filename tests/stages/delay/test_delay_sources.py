"""Several sources' delays: the K-peak pair search against a numpy reference, the closure
association (invariant to the order of the peaks), the per-channel bound shares, and the
transients → tde (peaks > 1) → localise chain on two simultaneous pulses; K = 1 unchanged."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from arrayproc.app.api import build_chain, run_chain
from arrayproc.errors import ConfigError
from arrayproc.geo import tdoa
from arrayproc.io.products import ProductsWriter, read_products
from arrayproc.io.recording import Recording, RecordingWriter
from arrayproc.stages.delay import bounds
from arrayproc.stages.delay._kernels import distinct_peaks
from arrayproc.stages.delay.closure import closure_hypotheses
from arrayproc.stages.delay.gcc import GccEstimator
from arrayproc.stages.delay.peaks import PairPeakEstimator, all_pairs

FS, C = 32000.0, 1484.0
BODY = np.array([[-0.86, -0.86, -0.67], [-0.86, -0.86, 0.48], [0.86, -0.86, -0.67],
                 [0.0, 0.0, 0.0], [-0.86, 0.86, -0.67], [0.86, 0.86, 0.67]])
BAND = (200.0, 4000.0)


def _pulses(rng, n, events, amp=30.0):
    """(n, 6) samples: Hann-tapered white pulses (20 ms, BAND) from body positions at their
    emission times, exact delays, 1/r spreading, unit white noise."""
    f = np.fft.rfftfreq(n, 1 / FS)
    inb = (f >= BAND[0]) & (f <= BAND[1])
    x = np.zeros((n, 6))
    m = int(0.02 * FS)
    for t_emit, src in events:
        p = np.zeros(n)
        p[:m] = rng.standard_normal(m) * np.hanning(m) * amp
        P = np.fft.rfft(p) * inb
        r = np.linalg.norm(BODY - src, axis=1)
        for ch in range(6):
            x[:, ch] += np.fft.irfft(P * np.exp(-2j * np.pi * f * (t_emit + r[ch] / C)), n) \
                / r[ch]
    return x + rng.standard_normal(x.shape)


# -- kernels against numpy references -----------------------------------------------------
def _distinct_ref(tau, h, ok, k, sep):
    out = np.full((tau.shape[0], k), -1)
    for i in range(tau.shape[0]):
        kept: list[int] = []
        for j in sorted(np.flatnonzero(ok[i]), key=lambda j: (-h[i, j], tau[i, j])):
            if len(kept) < k and all(abs(tau[i, j] - tau[i, q]) >= sep for q in kept):
                kept.append(int(j))
        out[i, :len(kept)] = kept
    return out


def test_distinct_peaks_kernel_matches_numpy_reference():
    rng = np.random.default_rng(4)
    tau = rng.uniform(-1e-3, 1e-3, (200, 12))
    h = rng.uniform(0, 1, (200, 12))
    ok = rng.uniform(size=(200, 12)) < 0.8
    for k, sep in ((1, 0.0), (3, 2e-4), (5, 5e-5)):
        np.testing.assert_array_equal(distinct_peaks(tau, h, ok, k, sep),
                                      _distinct_ref(tau, h, ok, k, sep))


def test_pair_peaks_match_a_dense_numpy_search():
    """Each kept peak is a maximum of the band-limited correlation r(τ) = Re Σ G e^{j2πfτ}
    evaluated densely in numpy (lag within 0.02 samples, height within 1e-9 relative)."""
    rng = np.random.default_rng(2)
    n = 2048
    x = _pulses(rng, n, [(0.01, np.array([2.0, 1.0, 0.5])),
                         (0.012, np.array([-2.5, -1.5, 1.0]))])
    pairs = all_pairs(6)
    lag = np.linalg.norm(BODY[pairs[:, 0]] - BODY[pairs[:, 1]], axis=1) / C + 1e-4
    est = PairPeakEstimator(n, FS, lag, pairs, 6, BAND, 3, "none")
    pk = est(x)
    X = est.gcc.spectra(x[None])[0]
    f = est.gcc.freqs
    for p, (a, b) in enumerate(pairs):
        G = X[b] * np.conj(X[a])
        grid = np.linspace(-lag[p], lag[p], 4001)
        r = (G[None, :] * np.exp(2j * np.pi * f[None, :] * grid[:, None])).real.sum(1)
        E = np.sqrt(np.sum(np.abs(X[a]) ** 2) * np.sum(np.abs(X[b]) ** 2))
        for q in np.flatnonzero(np.isfinite(pk.tau[0, p])):
            t = pk.tau[0, p, q]
            near = np.abs(grid - t) < 2.0 / FS
            j = np.flatnonzero(near)[np.argmax(r[near])]
            assert abs(grid[j] - t) < 0.02 / FS
            r_t = (G * np.exp(2j * np.pi * f * t)).real.sum()
            assert r_t >= r[near].max() * (1 - 1e-9)
            assert pk.corr[0, p, q] == pytest.approx(r_t / E, rel=1e-9)
        # the kept peaks are the highest local maxima at least 1/B apart
        kept = pk.tau[0, p][np.isfinite(pk.tau[0, p])]
        assert np.all(np.abs(np.subtract.outer(kept, kept))[~np.eye(kept.size, dtype=bool)]
                      >= est.min_sep)


def test_bound_shares_sum_to_the_pair_bound():
    T, lo, hi = 0.5, 100.0, 2000.0
    for s in (0.1, 1.0, 30.0):
        v = bounds.arrival_variance(s, T, lo, hi)
        assert 2 * v == pytest.approx(bounds.crlb(s, T, lo, hi) ** 2, rel=1e-12)
    v = np.array([1.0, 2.0, 3.0, 4.0]) * 1e-12
    C_ = tdoa.arrival_covariance(v, 1)
    np.testing.assert_allclose(C_, np.diag([1.0, 3.0, 4.0]) * 1e-12 + 2e-12, rtol=1e-15)
    # equal shares: the common-reference model of the σ
    w = np.full(4, 2e-12)
    np.testing.assert_allclose(tdoa.arrival_covariance(w, 0),
                               tdoa.reference_covariance(np.sqrt(np.full(3, 4e-12))),
                               rtol=1e-12)


# -- closure association --------------------------------------------------------------------
def _peak_set(rng, sources, k=3, noise=2e-6, spurious=1):
    """Synthetic peaks of every pair: the true lags of each source (σ = noise) plus
    ``spurious`` random lags per pair, padded with NaN to k."""
    pairs = all_pairs(6)
    arr = np.array([tdoa.predicted_delays(s, BODY, 0, C) for s in sources])   # τ_i − τ_0
    lag = arr[:, pairs[:, 1]] - arr[:, pairs[:, 0]]                           # (S, P)
    P = pairs.shape[0]
    tau = np.full((P, k), np.nan)
    sig = np.full((P, k), np.nan)
    cor = np.full((P, k), np.nan)
    lim = np.linalg.norm(BODY[pairs[:, 0]] - BODY[pairs[:, 1]], axis=1) / C
    for p in range(P):
        vals = list(lag[:, p] + rng.normal(0, noise, len(sources)))
        vals += list(rng.uniform(-lim[p], lim[p], spurious))
        cs = list(rng.uniform(0.5, 0.9, len(sources))) + list(rng.uniform(0.05, 0.3, spurious))
        m = min(k, len(vals))
        tau[p, :m], cor[p, :m], sig[p, :m] = vals[:m], cs[:m], noise
    return pairs, tau, sig, cor


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), data=st.data())
def test_closure_hypotheses_do_not_depend_on_the_order_of_the_peaks(seed, data):
    rng = np.random.default_rng(seed)
    sources = [np.array([3.0, 1.0, 0.5]), np.array([-2.0, -3.5, 1.0])]
    pairs, tau, sig, cor = _peak_set(rng, sources)
    ref = 3
    h0 = closure_hypotheses(tau, sig, cor, pairs, 6, ref, 3, 4.0, 5e-5, 0.7)
    perm = np.array([data.draw(st.permutations(range(tau.shape[1]))) for _ in pairs])
    take = np.arange(len(pairs))[:, None]
    h1 = closure_hypotheses(tau[take, perm], sig[take, perm], cor[take, perm], pairs, 6, ref,
                            3, 4.0, 5e-5, 0.7)
    np.testing.assert_array_equal(h0.tau, h1.tau)
    np.testing.assert_array_equal(h0.closure, h1.closure)
    # both sources found, each within a few σ of its true delays
    truth = np.array([tdoa.predicted_delays(s, BODY, ref, C) for s in sources])
    assert h0.tau.shape[0] >= 2
    for tr in truth:   # (a delay another source masks is left out: NaN)
        dev = np.nanmax(np.abs(h0.tau - tr), axis=1)
        best = int(np.argmin(dev))
        assert dev[best] < 2e-5 and np.isfinite(h0.tau[best]).sum() >= 5


def test_closure_with_one_source_gives_one_hypothesis():
    rng = np.random.default_rng(0)
    pairs, tau, sig, cor = _peak_set(rng, [np.array([1.5, -2.0, 0.3])], spurious=2)
    h = closure_hypotheses(tau, sig, cor, pairs, 6, 3, 3, 4.0, 5e-5, 0.7)
    assert h.tau.shape[0] == 1 and h.closure[0] == 1.0


# -- the chain -------------------------------------------------------------------------------
CHAIN = """
[input]
block = 8000

[[stage]]
type = "transients"
channel = 3
band = [200.0, 4000.0]
threshold_db = 10.0
background = 1.0
max_duration = 0.3

[[stage]]
type = "tde"
reference = 3
band = [200.0, 4000.0]
{extra}

[[stage]]
type = "localise"
min_corr = 0.2
"""


def _run(tmp_path, x, text, name):
    rec = tmp_path / f"{name}.h5"
    if not rec.exists():
        with RecordingWriter(rec, FS, 6, positions=BODY, sound_speed=C) as w:
            w.append(x.astype(np.float32))
    out = tmp_path / f"{name}_p.h5"
    with Recording(rec) as r, ProductsWriter(out, source=str(rec), chain=text) as pw:
        run_chain(r, build_chain(text), pw)
        world = np.asarray(r.pose(0.0).elements)
    A, *_ = np.linalg.lstsq(np.c_[BODY, np.ones(6)], world, rcond=None)
    return read_products(out), A


@pytest.fixture(scope="module")
def two_pulses():
    """0.384 s: noise, one 4096-sample snapshot holding two simultaneous 80 ms bursts (the
    frame case of :mod:`arrayproc.evaluate.multi_source`), noise."""
    from arrayproc.evaluate.multi_source import CASES, burst_frames

    case = CASES["frame"]()
    rng = np.random.default_rng(7)
    x, _ = burst_frames(rng, case)
    n = x.shape[0]
    full = np.concatenate([rng.standard_normal((n, 6)), x, rng.standard_normal((n, 6))])
    return full, list(case.sources), n


SNAPSHOTS = """
[[stage]]
type = "tde"
reference = 3
band = [200.0, 4000.0]
nfft = 4096
hop = 4096
{extra}

[[stage]]
type = "localise"
min_corr = 0.2
min_pairs = 4
"""


def test_two_simultaneous_sources_localised(tmp_path, two_pulses):
    x, srcs, n = two_pulses
    p, A = _run(tmp_path, x, SNAPSHOTS.format(extra="peaks = 3\nmax_sources = 2"), "two")
    d = p["tde"]
    t_mid = 1.5 * n / FS
    mid = np.isclose(d["time"], t_mid)
    assert mid.sum() == 2 and list(d["source"][mid]) == [0, 1]
    assert np.all(d["closure"][mid] >= 0.7)
    assert p["tde_peaks"]["tau"].shape == (3, 15, 3)
    assert p["tde_peaks"]["pairs"].shape == (15, 2)
    pos = p["localise"]
    m = np.isclose(pos["time"], t_mid)
    got = np.c_[pos["x"], pos["y"], pos["z"]][m]
    truth = np.array([np.r_[s, 1.0] @ A for s in srcs])
    assert got.shape[0] == 2 and sorted(pos["source"][m]) == [0, 1]
    err = np.linalg.norm(got[:, None] - truth[None], axis=-1)
    assert np.all(err.min(axis=1) < 0.1)
    assert set(np.argmin(err, axis=1)) == {0, 1}     # one position per source


def test_one_peak_output_is_the_one_peak_estimators(tmp_path, two_pulses):
    x, _, n = two_pulses
    p1, _ = _run(tmp_path, x, SNAPSHOTS.format(extra="peaks = 1"), "two")
    p0, _ = _run(tmp_path, x, SNAPSHOTS.format(extra=""), "two")
    assert "tde_peaks" not in p1 and "source" not in p1["tde"] and "source" not in p1["localise"]
    for k in ("time", "tau", "sigma", "corr"):
        assert np.asarray(p1["tde"][k]).tobytes() == np.asarray(p0["tde"][k]).tobytes()
    # and the one-peak estimator's own result on the snapshots
    with Recording(tmp_path / "two.h5") as r:
        pos = np.asarray(r.pose(0.0).elements)
    fr = x.astype(np.float32).reshape(3, n, 6)
    lim = np.linalg.norm(pos - pos[3], axis=1) / C + 1e-4
    d = GccEstimator(n, FS, 6, 3, BAND, lim)(fr)
    assert d.tau.tobytes() == np.asarray(p1["tde"]["tau"]).tobytes()


@pytest.mark.parametrize("extra, key", [("peaks = 2\nmethod = \"unwrap\"", "peaks"),
                                        ("peaks = 2\nweighting = \"ml\"", "weighting"),
                                        ("peaks = 2\ninterp = \"sinc\"", "interp"),
                                        ("peaks = 0", "peaks"),
                                        ("peaks = 2\nmin_closure = 1.5", "min_closure")])
def test_several_peak_config_errors_name_the_key(extra, key):
    with pytest.raises(ConfigError, match=key):
        build_chain(CHAIN.format(extra=extra))
