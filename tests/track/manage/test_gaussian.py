"""The stacked (many-track) EKF against FilterPy's one-track Kalman filter, and the
bearing-range-range-rate Jacobian against finite differences."""

from __future__ import annotations

import math

import numpy as np
import pytest

from arrayproc.track.filters.stacked import StackedEKF
from arrayproc.track.models.bearing_range_rate import BearingRangeRate
from arrayproc.track.models.frame import ObserverRelative
from arrayproc.track.models.motion import ConstantVelocity
from arrayproc.track.models.position import Position
from arrayproc.track.state import Context

filterpy = pytest.importorskip("filterpy.kalman")


def _random_spd(rng, n, k):
    A = rng.standard_normal((n, k, k))
    return A @ A.transpose(0, 2, 1) + k * np.eye(k)


def test_kalman_batch_equals_filterpy():
    rng = np.random.default_rng(1)
    motion = ConstantVelocity(q1=0.3, axes=2)
    H = np.array([[1.0, 0, 0, 0], [0, 1.0, 0, 0]])
    R = np.diag([4.0, 9.0])
    kb = StackedEKF(motion, Position(axes=2))
    X = rng.standard_normal((5, 4)) * 10
    P = _random_spd(rng, 5, 4)
    dt = rng.uniform(0.5, 3, 5)
    Z = rng.standard_normal((5, 2)) * 10
    Xp, Pp = kb.predict(X, P, dt)
    ctx = Context(np.zeros(4), meas_cov=np.broadcast_to(R, (5, 2, 2)))
    Xu, Pu, ll = kb.update(Xp, Pp, Z, ctx, np.arange(5))
    for i in range(5):
        kf = filterpy.KalmanFilter(4, 2)
        F, Q = motion.transition_stacked(dt[i:i + 1]), motion.covariance_stacked(dt[i:i + 1])
        kf.x, kf.P, kf.F, kf.Q, kf.H, kf.R = X[i].copy(), P[i].copy(), F[0], Q[0], H, R
        kf.predict()
        np.testing.assert_allclose(Xp[i], kf.x, rtol=1e-12, atol=1e-9)
        np.testing.assert_allclose(Pp[i], kf.P, rtol=1e-12, atol=1e-9)
        kf.update(Z[i])
        np.testing.assert_allclose(Xu[i], kf.x, rtol=1e-10, atol=1e-9)
        np.testing.assert_allclose(Pu[i], kf.P, rtol=1e-10, atol=1e-9)
        assert ll[i] == pytest.approx(kf.log_likelihood, rel=1e-10)


def test_cv_process_noise_closed_form():
    cv = ConstantVelocity(q1=2.0, axes=1)
    F, Q = cv.transition_stacked(np.array([3.0])), cv.covariance_stacked(np.array([3.0]))
    np.testing.assert_allclose(F[0], [[1, 3], [0, 1]])
    np.testing.assert_allclose(Q[0], 2.0 * np.array([[9.0, 4.5], [4.5, 3.0]]))


def test_brr_jacobian_and_inverse():
    m = ObserverRelative(BearingRangeRate.from_degrees(1.0, 10.0, 0.1))
    own = np.array([100.0, -50.0, 2.0, 1.0])
    ctx = Context(own)
    X = np.array([[3000.0, 4000.0, -3.0, 2.0], [-2000.0, 500.0, 1.0, -4.0]])
    J = m.jacobian_stacked(X, ctx)
    eps = 1e-4
    for a in range(4):
        d = np.zeros(4)
        d[a] = eps
        num = (m.function_stacked(X + d, ctx) - m.function_stacked(X - d, ctx)) / (2 * eps)
        np.testing.assert_allclose(J[:, :, a], num, rtol=1e-6, atol=1e-9)
    z = m.function_stacked(X[:1], ctx)[0]
    x0, P0 = m.model.inverse(z, own, sigma_speed=5.0)
    np.testing.assert_allclose(x0[:2], X[0, :2], rtol=1e-12)
    # the velocity along the line of sight is recovered (range rate), the rest unobserved
    u = (X[0, :2] - own[:2]) / np.linalg.norm(X[0, :2] - own[:2])
    assert (x0[2:] - own[2:]) @ u == pytest.approx((X[0, 2:] - own[2:]) @ u)
    assert np.all(np.linalg.eigvalsh(P0) > 0)
    # bearing clockwise from north, range rate positive opening
    c0 = Context(np.zeros(4))
    assert m.function_stacked(np.array([[0.0, 1000.0, 0.0, 5.0]]), c0)[0] == pytest.approx(
        [0.0, 1000.0, 5.0])
    assert m.function_stacked(np.array([[1000.0, 0.0, 0.0, 0.0]]), c0)[0, 0] == \
        pytest.approx(math.pi / 2)


def test_ekf_batch_wraps_bearing_innovation():
    m = ObserverRelative(BearingRangeRate.from_degrees(1.0, 10.0, 0.1))
    ekf = StackedEKF(ConstantVelocity(q1=0.01, axes=2), m)
    X = np.array([[-10.0, -1000.0, 0.0, 0.0]])  # bearing just under 180° (−179.4°)
    P = np.diag([100.0, 100.0, 1.0, 1.0])[None]
    z = np.array([[math.radians(179.5), 1000.0, 0.0]])
    nu, S = ekf.innovation(X, P, z, Context(np.zeros(4)))
    assert abs(nu[0, 0, 0]) < math.radians(2.0)
    Xu, Pu, ll = ekf.update(X, P, z, Context(np.zeros(4)), np.array([0]))
    assert np.isfinite(ll[0]) and np.linalg.norm(Xu[0, :2] - X[0, :2]) < 30.0
