"""FIM / CRLB of the batch TMA methods: numerical Jacobians, closed forms, observability."""

from __future__ import annotations

import numpy as np
import pytest

from arrayproc.track.batch import scenarios as S
from arrayproc.track.batch.bo_tma import bearing_model
from arrayproc.track.batch.compact import compact_bearings, state_covariance
from arrayproc.track.batch.fim import (
    bo_fim,
    compact_fim,
    compact_jacobian,
    condition_number,
    crlb_from_fim,
    range_sigma,
    td_fim,
)
from arrayproc.track.batch.td_tma import delay_model

from ._reference import exp_cov


def numjac(f, x, h):
    x = np.asarray(x, float)
    cols = []
    for i in range(x.size):
        d = np.zeros_like(x)
        d[i] = h[i]
        cols.append((f(x + d) - f(x - d)) / (2 * h[i]))
    return np.stack(cols, -1)


H4 = np.array([1e-3, 1e-3, 1e-5, 1e-5])


def assert_fim_close(a, b, tol):
    """Entries compared relative to √(J_ii J_jj) (cross terms cancel in part)."""
    d = np.sqrt(np.outer(np.diag(b), np.diag(b)))
    assert np.max(np.abs(a - b) / d) < tol, np.max(np.abs(a - b) / d)


def test_bo_fim_equals_numerical_jacobian_fim():
    tr = S.turn_track()
    x = S.FIG_3_18_SOURCE
    sig = np.deg2rad(0.0306)
    g = numjac(lambda s: bearing_model(s, tr.time, tr.position), x, H4)
    np.testing.assert_allclose(bo_fim(x, tr.time, tr.position, sig), g.T @ g / sig**2,
                               rtol=1e-6)


def test_td_fim_equals_numerical_jacobian_fim():
    tr = S.turn_track(dt=10.0)
    el = S.line_elements(tr, 32, 0.36)
    x = S.FIG_3_18_SOURCE
    g = numjac(lambda s: delay_model(s, tr.time, el, 0, 1500.0).ravel(), x, H4)
    np.testing.assert_allclose(td_fim(x, tr.time, el, 0, 1500.0, 1e-4), g.T @ g / 1e-8,
                               rtol=1e-5)


def test_retarded_bo_fim_equals_numerical_jacobian_fim():
    """Source at its emission time (motion eq. M5): the exact derivative M⁻¹ [I, τ_e I]."""
    tr = S.turn_track()
    x = np.array([2000.0, 1000.0, -6.0, 4.0])
    sig = np.deg2rad(0.0306)
    g = numjac(lambda s: bearing_model(s, tr.time, tr.position, 1500.0), x, H4)
    f = bo_fim(x, tr.time, tr.position, sig, 1500.0)
    # the model iterates (M5) N_RETARD times, the FIM uses the converged derivative: they
    # differ by O((v/c)³) ≈ 1e-7 relative at 7 m/s
    assert_fim_close(f, g.T @ g / sig**2, 1e-6)
    # it differs from the thesis model's FIM by more than the tolerance
    assert np.max(np.abs(f / bo_fim(x, tr.time, tr.position, sig) - 1)) > 1e-4


def test_retarded_3d_td_fim_equals_numerical_jacobian_fim():
    tr = S.turn_track(dt=10.0)
    el = S.line_elements(tr, 32, 0.36)
    dz = np.full(el.shape[:2], 45.0) + np.linspace(0, 3, 32)[None, :]
    x = np.array([2000.0, 1000.0, -6.0, 4.0])
    g = numjac(lambda s: delay_model(s, tr.time, el, 0, 1500.0, True, dz).ravel(), x, H4)
    f = td_fim(x, tr.time, el, 0, 1500.0, 1e-4, True, dz)
    assert_fim_close(f, g.T @ g / 1e-8, 1e-6)
    assert np.max(np.abs(f / td_fim(x, tr.time, el, 0, 1500.0, 1e-4) - 1)) > 1e-4
    xs = np.stack([x, [-3000.0, 500.0, 2.0, -1.0]])
    np.testing.assert_allclose(td_fim(xs, tr.time, el, 0, 1500.0, 1e-4, True, dz)[0], f)


def test_td_fim_batches_states():
    tr = S.turn_track(dt=30.0)
    el = S.line_elements(tr, 8, 0.36)
    xs = np.array([S.FIG_3_18_SOURCE, [-3000.0, 500.0, 2.0, -1.0]])
    batch = td_fim(xs, tr.time, el, 0, 1500.0, 1e-4)
    for k in range(2):
        np.testing.assert_allclose(batch[k], td_fim(xs[k], tr.time, el, 0, 1500.0, 1e-4))


def test_plane_wave_bearing_information_is_appendix_c6():
    """Thesis eq. (C.6): one snapshot of a far source; the TD information on the bearing is
    (δ sin θ / (σ_τ c))² N(N−1)(2N−1)/6."""
    n, dx, c, st = 64, 0.36, 1500.0, 1e-5
    el = (np.arange(n) * dx)[None, :, None] * np.array([0.0, -1.0])[None, None, :]  # heading 0
    theta = np.deg2rad(70.0)
    r = 5e6   # far field: curvature negligible
    x = np.array([r * np.sin(theta), r * np.cos(theta), 0.0, 0.0])
    f = td_fim(x, np.zeros(1), el, 0, c, st)[:2, :2]
    tang = np.array([np.cos(theta), -np.sin(theta)]) * r      # ∂position/∂θ
    j_theta = tang @ f @ tang
    closed = (dx * np.sin(theta) / (st * c)) ** 2 * n * (n - 1) * (2 * n - 1) / 6
    np.testing.assert_allclose(j_theta, closed, rtol=1e-5)


def test_parallel_track_bearings_singular_delays_definite():
    """Thesis fig. 3.23: no ownship manoeuvre, bearings FIM singular, delays FIM definite."""
    tr = S.parallel_track()
    el = S.line_elements(tr)
    x = np.array([1500.0, 1500.0, 0.0, 3.0])
    fb = bo_fim(x, tr.time, tr.position, np.deg2rad(0.0306))
    fd = td_fim(x, tr.time, el, 0, 1500.0, 1e-4)
    cb, pdb = crlb_from_fim(fb)
    cd, pdd = crlb_from_fim(fd)
    assert not pdb and np.all(np.isnan(cb))
    assert np.isinf(condition_number(fb)) or condition_number(fb) > 1e15
    assert pdd and np.isfinite(range_sigma(x[:2], cd))


def test_turn_makes_bearings_observable():
    tr = S.turn_track()
    c, pd = crlb_from_fim(bo_fim(S.FIG_3_18_SOURCE, tr.time, tr.position, 1e-3))
    assert pd and np.all(np.diag(c) > 0)


def test_range_sigma_is_radial_variance():
    """eq. (3.55): the variance of the range, uᵀ P u, u the unit radial vector."""
    rng = np.random.default_rng(0)
    a = rng.normal(size=(4, 4))
    p = a @ a.T
    xy = np.array([1200.0, -700.0])
    u = xy / np.hypot(*xy)
    np.testing.assert_allclose(range_sigma(xy, p), np.sqrt(u @ p[:2, :2] @ u))


@pytest.mark.parametrize("corr", [0.0, 30.0])
def test_compact_fim_equals_numerical_with_dense_covariance(corr):
    t = np.arange(0.0, 600.0, 4.0)
    q = np.array([-2000.0, 500.0, np.deg2rad(80.0)])
    v, sig, sv = 7.3, np.deg2rad(1.5), 0.7
    g = numjac(lambda p: compact_bearings(p[:3], p[3], t, [0.0, 0.0]), np.append(q, v),
               np.array([1e-3, 1e-3, 1e-7, 1e-6]))
    ref = g.T @ np.linalg.solve(exp_cov(t, sig, corr), g) + np.diag([0, 0, 0, 1 / sv**2])
    np.testing.assert_allclose(compact_fim(q, v, t, [0.0, 0.0], sig, corr, sv), ref,
                               rtol=1e-6)
    np.testing.assert_allclose(compact_fim(q, v, t, [0.0, 0.0], sig, corr), ref[:3, :3],
                               rtol=1e-6)


def test_compact_speed_scale_invariance_in_bound():
    """Bearings are unchanged by scaling range and speed together, so without the prior the
    information on (x0, y0, γ, v) is singular; the speed prior makes it definite."""
    t = np.arange(0.0, 600.0, 4.0)
    q = np.array([-2000.0, 500.0, np.deg2rad(80.0)])
    g = compact_jacobian(q, 7.3, t, [0.0, 0.0]) / 0.02
    assert not crlb_from_fim(g.T @ g)[1]
    # the singular direction is the scaling (x0, y0, 0, v)
    np.testing.assert_allclose(g @ np.array([q[0], q[1], 0.0, 7.3]), 0.0, atol=1e-9)
    assert crlb_from_fim(compact_fim(q, 7.3, t, [0.0, 0.0], 0.02, 0.0, 0.5))[1]


def test_state_covariance_velocity_from_heading_and_speed():
    q = np.array([0.0, 0.0, np.deg2rad(30.0)])
    p = np.diag([1.0, 2.0, 1e-4, 0.25])
    c = state_covariance(q, 5.0, p)
    rng = np.random.default_rng(0)
    g = q[2] + rng.normal(0, 1e-2, 200_000)
    v = 5.0 + rng.normal(0, 0.5, 200_000)
    emp = np.cov(np.stack([v * np.sin(g), v * np.cos(g)]))
    np.testing.assert_allclose(c[2:, 2:], emp, rtol=0.03, atol=2e-4)
