"""numba kernels of the batch TMA objectives against plain numpy references."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from arrayproc.track.batch import _kernels as K
from arrayproc.track.batch import scenarios as S
from arrayproc.track.batch.fim import innovation_coefficients, whiten

from ._reference import bo_cost, compact_cost_dense, exp_cov, td_cost

# normal (not subnormal) floats and zero: positions in metres never come near 1e-300
finite = st.one_of(st.just(0.0), st.floats(1e-200, 1e6).flatmap(
    lambda v: st.sampled_from([v, -v])))


@settings(max_examples=300, deadline=None)
@given(finite, finite)
def test_atan2_matches_numpy(y, x):
    got = K.atan2_array(np.array([y]), np.array([x]))[0]
    ref = np.arctan2(y, x)
    # same angle (±π and −π are the same direction when y = ±0)
    assert abs(K.wrap_pi(got - ref)) <= 4 * np.spacing(np.pi)


def test_atan2_dense_sweep():
    rng = np.random.default_rng(3)
    y = rng.normal(size=200_000) * rng.choice([1e-9, 1.0, 1e6], 200_000)
    x = rng.normal(size=200_000) * rng.choice([1e-9, 1.0, 1e6], 200_000)
    assert np.max(np.abs(K.atan2_array(y, x) - np.arctan2(y, x))) <= 2 * np.spacing(np.pi)


def test_bo_cost_population_matches_numpy():
    rng = np.random.default_rng(0)
    tr = S.turn_track()
    pop = np.ascontiguousarray(np.vstack([rng.uniform(-5e3, 5e3, (2, 50)),
                                          rng.uniform(-10, 10, (2, 50))]))
    meas = rng.uniform(-np.pi, np.pi, tr.time.size)
    w = rng.uniform(0.5, 2.0, tr.time.size)
    got = K.bo_cost_population(pop, tr.time, tr.position, meas, w)
    np.testing.assert_allclose(got, bo_cost(pop, tr.time, tr.position, meas, w), rtol=1e-12)
    # source at the emission time (motion eq. M5)
    got = K.bo_cost_population(pop, tr.time, tr.position, meas, w, 1 / 1500.0)
    ref = bo_cost(pop, tr.time, tr.position, meas, w, 1500.0)
    np.testing.assert_allclose(got, ref, rtol=1e-11)
    assert np.max(np.abs(ref / bo_cost(pop, tr.time, tr.position, meas, w) - 1)) > 1e-6


def test_td_cost_population_matches_numpy():
    rng = np.random.default_rng(1)
    tr = S.turn_track(dt=20.0)
    el = np.ascontiguousarray(S.line_elements(tr, 16, 0.36))
    pop = np.ascontiguousarray(np.vstack([rng.uniform(-5e3, 5e3, (2, 40)),
                                          rng.uniform(-10, 10, (2, 40))]))
    meas = rng.normal(0, 1e-3, (tr.time.size, 16))
    w = rng.uniform(0.5, 2.0, meas.shape) * 1e3
    w[:, 3] = 0.0
    ex, ey = np.ascontiguousarray(el[..., 0]), np.ascontiguousarray(el[..., 1])
    zero = np.zeros(meas.shape)
    got = K.td_cost_population(pop, tr.time, ex, ey, zero, w * meas, w / 1500.0, 3)
    np.testing.assert_allclose(got, td_cost(pop, tr.time, el, meas, w, 3, 1500.0), rtol=1e-10)
    # depth differences and the source at the emission time (motion eq. M5)
    dz2 = rng.uniform(0.0, 60.0, meas.shape) ** 2
    got = K.td_cost_population(pop, tr.time, ex, ey, dz2, w * meas, w / 1500.0, 3, 1 / 1500.0)
    ref = td_cost(pop, tr.time, el, meas, w, 3, 1500.0, dz2, retarded=True)
    np.testing.assert_allclose(got, ref, rtol=1e-10)
    assert np.max(np.abs(ref / td_cost(pop, tr.time, el, meas, w, 3, 1500.0) - 1)) > 1e-6


def test_innovations_equal_dense_quadratic_form():
    rng = np.random.default_rng(2)
    t = np.cumsum(rng.uniform(0.5, 6.0, 80))
    e = rng.normal(size=80)
    for corr in (0.0, 3.0, 40.0):
        phi, sc = innovation_coefficients(t, 0.02, corr)
        q = np.sum(whiten(e, phi, sc) ** 2)
        c = exp_cov(t, 0.02, corr)
        np.testing.assert_allclose(q, e @ np.linalg.solve(c, e), rtol=1e-9)


def test_compact_grid_matches_dense_covariance():
    rng = np.random.default_rng(4)
    t = np.cumsum(rng.uniform(1.0, 5.0, 60))
    tau = t - t[0]
    meas = rng.uniform(-np.pi, np.pi, 60)
    xs = np.linspace(-2000, 2500, 9)
    ys = np.linspace(-1500, 3000, 7)
    hd = np.deg2rad(np.arange(0, 360, 45.0))
    a = np.array([30.0, -20.0])
    for corr in (0.0, 25.0):
        phi, sc = innovation_coefficients(t, 0.03, corr)
        got = K.compact_grid_cost(xs, ys, hd, 7.3, tau, a, meas, phi, sc)
        ref = compact_cost_dense(xs, ys, hd, 7.3, tau, a, meas, exp_cov(t, 0.03, corr))
        np.testing.assert_allclose(got, ref, rtol=1e-8)


def test_td_model_jacobian_matches_numpy():
    """The polish kernel against delay_model and fim.td_jacobian (planar / 3-D, source at the
    measurement or the emission time)."""
    from arrayproc.track.batch.fim import td_jacobian
    from arrayproc.track.batch.td_tma import delay_model

    rng = np.random.default_rng(5)
    tr = S.turn_track(dt=20.0)
    el = S.line_elements(tr, 24, 0.5)
    ex, ey = np.ascontiguousarray(el[..., 0]), np.ascontiguousarray(el[..., 1])
    dz = rng.uniform(0.0, 60.0, el.shape[:2])
    for _ in range(5):
        x = np.r_[rng.uniform(-5e3, 5e3, 2), rng.uniform(-10, 10, 2)]
        for ret in (False, True):
            for d in (None, dz):
                d2 = np.zeros(el.shape[:2]) if d is None else d**2
                h, j = K.td_model_jacobian(x, tr.time, ex, ey, d2, 2, 1500.0, ret)
                h_ref = delay_model(x, tr.time, el, 2, 1500.0, ret, d)
                j_ref = td_jacobian(x, tr.time, el, 2, 1500.0, ret, d)
                # range differences of km ranges: rounding ~ε r/c ≈ 1e-15 s
                np.testing.assert_allclose(h, h_ref, rtol=0, atol=2e-14)
                # differences of unit vectors, O(aperture/range): rounding ~1e-12 relative
                scale = np.abs(j_ref).max((0, 1))
                assert np.all(np.abs(j - j_ref) <= 1e-11 * scale)
