"""RPF numba kernels against the plain-numpy reference on the same random stream."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from arrayproc.track.filters import _pf_kernels as k
from tests import pf_reference as ref

SEED = 0x1234_5678_9ABC_DEF0


def _state(seed=SEED):
    return np.array([seed], dtype=np.uint64)


def test_uniform_stream_matches_python_splitmix64():
    got = k.uniform_block(_state(), 1000)
    exp = ref.Stream(SEED).uniforms(1000)
    np.testing.assert_array_equal(got, exp)
    # canonical SplitMix64 first output for seed 0 (Vigna's reference implementation)
    assert int(ref.splitmix64_block(0, 0, 1)[0]) == 0xE220A8397B1DCDAF
    assert np.all((got > 0) & (got <= 1))


def test_normals_and_kernel_draws_match_reference():
    np.testing.assert_allclose(k.normal_block(_state(), 500), ref.Stream(SEED).normal_pairs(500),
                               rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(k.epanechnikov_block(_state(), 300),
                               ref.Stream(SEED).epanechnikov(300), rtol=1e-13, atol=1e-15)


def test_normal_distribution():
    z = k.normal_block(_state(7), 100_000).ravel()
    assert abs(z.mean()) < 0.01 and abs(z.std() - 1) < 0.01
    assert stats.kstest(z, "norm").pvalue > 1e-3


def test_epanechnikov_kernel_distribution():
    """SPL paper eq. (26) in R^4: support the unit ball, ‖ε‖² ~ Beta(2, 2), isotropic with
    E[ε εᵀ] = I / (n_x + 4)."""
    e = k.epanechnikov_block(_state(11), 100_000)
    r2 = np.sum(e**2, axis=1)
    assert r2.max() < 1.0
    assert stats.kstest(r2, stats.beta(2, 2).cdf).pvalue > 1e-3
    np.testing.assert_allclose(e.T @ e / e.shape[0], np.eye(4) / 8, atol=3e-3)


def test_bandwidth_eq27_28():
    for n in (100, 5000):
        assert k.bandwidth(n) == pytest.approx(ref.bandwidth(n), rel=1e-14)
    # A(K) for n_x = 4: (8 · 2/π² · 8 · 16 π²)^(1/8) = 2048^(1/8)
    assert k.A_K == pytest.approx(2048 ** 0.125, rel=1e-14)


def _cloud(n, seed=3):
    g = np.random.default_rng(seed)
    return np.column_stack([g.normal(6000, 2000, n), g.normal(-3000, 2000, n),
                            g.normal(0, 2, n), g.normal(0, 2, n)])


TL = (0.0, 20.0, 60.0 + 15.0 * np.log10(1.0 + np.arange(2501) * 20.0 / 100.0))
SL = np.array([170.0, 53.0, 5.14])


@pytest.mark.parametrize("use_theta,use_level", [(True, False), (True, True), (False, True)])
def test_predict_loglik_matches_reference(use_theta, use_level):
    x = _cloud(400)
    xk = x.copy()
    ll = np.empty(400)
    m = k.predict_loglik(xk, ll, _state(), 60.0, 0.01, 100.0, -50.0, 2.0, 0.03, 80.0, 10.0,
                         use_theta, use_level, SL, *TL)
    s = ref.Stream(SEED)
    xr = ref.propagate(s, x, 60.0, 0.01)
    llr = ref.loglik(xr, np.array([100.0, -50.0]), 2.0, 0.03, 80.0, 10.0, use_theta,
                     use_level, SL, TL)
    np.testing.assert_allclose(xk, xr, rtol=1e-13, atol=1e-9)
    np.testing.assert_allclose(ll, llr, rtol=1e-10, atol=1e-10)
    assert m == ll.max()


def test_reweight_and_moments_match_reference():
    g = np.random.default_rng(5)
    w = g.random(300) * 3.0
    ll = -g.random(300) * 50
    out = np.empty(300)
    s, neff = k.reweight(w, w.sum(), ll, ll.max(), out)
    wr = w * np.exp(ll)
    wr /= wr.sum()
    np.testing.assert_allclose(out / s, wr, rtol=1e-12)
    assert neff == pytest.approx(1 / np.sum(wr**2), rel=1e-12)
    x = _cloud(300)
    mean, cov = np.empty(4), np.empty((4, 4))
    k._moments(x, out, s, mean, cov)
    mr, cr = ref.mean_cov(x, wr)
    np.testing.assert_allclose(mean, mr, rtol=1e-12)
    np.testing.assert_allclose(cov, cr, rtol=1e-9, atol=1e-9 * np.abs(cr).max())


def test_reweight_survives_underflow():
    w = np.ones(50)
    ll = np.full(50, -1e4)
    ll[7] = -10.0
    out = np.empty(50)
    s, neff = k.reweight(w, 50.0, ll, 0.0, out)      # stale max: every product underflows
    assert np.isfinite(s) and s > 0 and neff == pytest.approx(1.0)
    assert out[7] / s == pytest.approx(1.0)


@settings(max_examples=25, deadline=None)
@given(st.integers(2, 400), st.integers(0, 2**63 - 1), st.sampled_from([0, 1]))
def test_resampling_matches_reference(n, seed, method):
    w = np.random.default_rng(seed % 1000).random(n) ** 3 + 1e-12
    idx = np.empty(n, np.int64)
    if method == 0:
        k.systematic_resample(w, w.sum(), idx, _state(seed))
    else:
        k.multinomial_resample(w, w.sum(), idx, _state(seed))
    exp = ref.resample(ref.Stream(seed), w, "systematic" if method == 0 else "multinomial")
    np.testing.assert_array_equal(idx, exp)
    assert np.all(np.diff(idx) >= 0)
    if method == 0:   # systematic: each count within 1 of N w_i
        counts = np.bincount(idx, minlength=n)
        assert np.all(np.abs(counts - n * w / w.sum()) < 1.0 + 1e-9)


def test_cholesky_and_regularise_match_reference():
    x = _cloud(200)
    p = np.cov(x.T, bias=True)
    d = np.empty((4, 4))
    assert k.cholesky4(p, d)
    np.testing.assert_allclose(d, np.linalg.cholesky(p + 1e-10 * np.diag(np.diag(p))),
                               rtol=1e-12)
    idx = np.sort(np.random.default_rng(9).integers(0, 200, 200))
    out = np.empty_like(x)
    k.regularise(out, x, idx, d, 0.5, _state())
    exp = x[idx] + 0.5 * ref.Stream(SEED).epanechnikov(200) @ d.T
    np.testing.assert_allclose(out, exp, rtol=1e-12, atol=1e-9)


def test_cholesky_of_a_degenerate_cloud_stays_bounded():
    """All particles on a line (rank-1 covariance, rounding noise in the Schur complements):
    the factor must stay of the size of the standard deviations (a regression: dividing by
    a rounding-error pivot once sent a velocity to 4e7 m/s)."""
    g = np.random.default_rng(1)
    t = g.normal(size=500)
    x = np.column_stack([4000 + 30 * t, -1400 + 9 * t, 0.06 * t - 1.1, 0.009 * t - 1.8])
    p = np.cov(x.T, bias=True)
    d = np.empty((4, 4))
    assert k.cholesky4(p, d)
    assert np.all(np.isfinite(d))
    assert np.all(np.abs(d) <= np.sqrt((1 + 1e-9) * np.diag(p))[:, None])
    np.testing.assert_allclose(d @ d.T, p, rtol=1e-6, atol=1e-8 * np.abs(p).max())
    zero = p.copy()
    zero[3, :] = zero[:, 3] = 0.0                    # a dimension with no spread
    assert k.cholesky4(zero, d) and np.all(d[3] == 0.0) and np.all(np.isfinite(d))
    bad = p.copy()
    bad[0, 0] = np.nan
    assert not k.cholesky4(bad, d)


def _run_setup(n_steps=15):
    times = np.arange(n_steps) * 60.0
    obs = np.column_stack([np.sin(times / 400.0) * 800.0, times * 1.5])
    tgt = np.column_stack([5000 - 1.6 * times, 800 - 1.9 * times])
    d = tgt - obs
    g = np.random.default_rng(2)
    theta = np.mod(np.arctan2(d[:, 0], d[:, 1]) + 0.02 * g.standard_normal(n_steps), 2 * np.pi)
    r = np.hypot(d[:, 0], d[:, 1])
    level = 170 + 53 * np.log10(2.5 / 5.14) - np.interp(r, TL[0] + TL[1] * np.arange(2501),
                                                         TL[2]) + 4 * g.standard_normal(n_steps)
    prior = np.array([10e3, 2e3, 1.54, 1.03, math.pi, math.pi / math.sqrt(12), 100.0])
    return times, obs, theta, level, prior


@pytest.mark.parametrize("use_level,method", [(False, 0), (True, 0), (True, 1)])
def test_full_rpf_run_matches_numpy_reference(use_level, method):
    times, obs, theta, level, prior = _run_setup()
    n = 300
    est = np.empty((times.size, 4))
    cov = np.empty((times.size, 4, 4))
    flags = np.zeros(times.size, np.bool_)
    k.rpf_run(theta, level, False, use_level, times, obs, np.uint64(SEED), n, 1 / 3, 1.5e-3,
              0.02, 10.0, prior, SL, *TL, method, 1.0, est, cov, flags)
    er, cr, fr = ref.rpf(theta, level, use_level, times, obs, SEED, n, 1 / 3, 1.5e-3, 0.02,
                         10.0, prior, SL, TL, "systematic" if method == 0 else "multinomial")
    assert fr.sum() >= 3                       # the run exercises regularization-resampling
    np.testing.assert_array_equal(flags, fr)
    np.testing.assert_allclose(est, er, rtol=1e-8, atol=1e-6)
    np.testing.assert_allclose(cov, cr, rtol=1e-6, atol=1e-6 * np.abs(cr).max())


def test_monte_carlo_is_reproducible_and_thread_independent():
    import numba

    times, obs, theta, level, prior = _run_setup(8)
    th = np.tile(theta, (4, 1))
    lv = np.tile(level, (4, 1))
    seeds = np.arange(1, 5, dtype=np.uint64) * np.uint64(977)

    def go():
        est = np.empty((4, times.size, 4))
        cov = np.empty((4, times.size, 4, 4))
        fl = np.zeros((4, times.size), np.bool_)
        k.rpf_monte_carlo(th, lv, False, True, times, obs, seeds, 200, 1 / 3, 1.5e-3, 0.02,
                          10.0, prior, SL, *TL, 0, 1.0, est, cov, fl)
        return est

    a = go()
    old = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        b = go()
    finally:
        numba.set_num_threads(old)
    assert a.tobytes() == b.tobytes()
    one = np.empty((times.size, 4))
    k.rpf_run(th[2], lv[2], False, True, times, obs, seeds[2], 200, 1 / 3, 1.5e-3, 0.02, 10.0,
              prior, SL, *TL, 0, 1.0, one, np.empty((times.size, 4, 4)),
              np.zeros(times.size, np.bool_))
    assert one.tobytes() == a[2].tobytes()
    assert not np.array_equal(a[0], a[1])        # different seeds, different runs


@pytest.mark.parametrize("use_level", [False, True])
def test_rpf_uniform_course_and_speed_gate_match_numpy_reference(use_level):
    """The uniform course prior and the speed gate (prior[7], prior[8]) against the reference;
    a 2.5 m/s gate rejects a good share of the 1.54 ± 1.03 m/s prior."""
    times, obs, theta, level, prior = _run_setup()
    pr = np.concatenate([prior, [1.0, 2.5]])
    n = 300
    est = np.empty((times.size, 4))
    cov = np.empty((times.size, 4, 4))
    flags = np.zeros(times.size, np.bool_)
    k.rpf_run(theta, level, False, use_level, times, obs, np.uint64(SEED), n, 1 / 3, 1.5e-3,
              0.02, 10.0, pr, SL, *TL, 0, 1.0, est, cov, flags)
    er, cr, fr = ref.rpf(theta, level, use_level, times, obs, SEED, n, 1 / 3, 1.5e-3, 0.02,
                         10.0, pr, SL, TL, "systematic")
    np.testing.assert_array_equal(flags, fr)
    np.testing.assert_allclose(est, er, rtol=1e-8, atol=1e-6)
    np.testing.assert_allclose(cov, cr, rtol=1e-6, atol=1e-6 * np.abs(cr).max())
    assert np.all(np.hypot(est[1:, 2], est[1:, 3]) < 2.5)  # the estimate respects the gate


def test_uniform_course_prior_moments():
    """Uniform course draws: mean θ0 + offset, standard deviation course_std, support ±√3·std."""
    n = 40000
    parts = np.empty((n, 4))
    st = np.array([SEED], np.uint64)
    std = math.pi / math.sqrt(12.0)
    k.init_polar_prior(parts, st, 0.0, 0.0, 0.3, 0.01, 10e3, 1.0, 2.0, 1e-9, 0.3 + math.pi,
                       std, 100.0, True)
    c = np.arctan2(parts[:, 2], parts[:, 3])
    d = np.mod(c - (0.3 + math.pi) + math.pi, 2 * math.pi) - math.pi
    assert abs(d.mean()) < 0.01
    assert abs(d.std() - std) < 0.01
    assert np.abs(d).max() <= math.pi / 2 + 1e-9


def test_speed_gate_never_rejects_every_particle():
    parts = np.zeros((4, 4))
    parts[:, 2] = [1.0, 2.0, 3.0, 4.0]
    ll = np.array([-1.0, -2.0, -3.0, -0.5])
    w = np.ones(4)
    m = k.speed_gate(parts, w, ll, 2.5, ll.max())
    assert m == -1.0 and np.isneginf(ll[2:]).all() and ll[0] == -1.0
    ll2 = np.array([-1.0, -2.0, -3.0, -0.5])
    w[:2] = 0.0  # the only particles inside the gate carry no weight: leave everything alone
    assert k.speed_gate(parts, w, ll2, 2.5, -0.5) == -0.5 and np.all(np.isfinite(ll2))
    assert k.speed_gate(parts, np.ones(4), ll2, 0.0, -0.5) == -0.5  # off
