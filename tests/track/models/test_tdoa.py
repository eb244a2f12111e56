"""A new measurement type is one new file: the TDOA model (thesis eqs. (3.37)-(3.40)) runs
through the unchanged EKF and UKF; their vector-measurement updates against numpy."""

from __future__ import annotations

import math

import numpy as np
import pytest

from arrayproc.track.filters import EKF, UKF, make_filter
from arrayproc.track.models.motion import constant_velocity
from arrayproc.track.models.tdoa import TDOA
from arrayproc.track.state import Context

C = 1500.0
ELEMENTS = np.array([[0.0, 0.0, 0.0], [300.0, 0.0, 10.0], [0.0, 300.0, 20.0],
                     [-250.0, -150.0, 30.0]])
OWN = np.zeros(4)
CTX = Context(OWN, OWN)


def _model(sigma=2e-5):
    return TDOA(elements=ELEMENTS, reference=0, sound_speed=C, sigma_s=sigma, source_dz_m=50.0)


def test_tdoa_function_is_eqs_3_38_3_39():
    m = _model()
    s = np.array([1200.0, -700.0, 1.0, 2.0])
    src = np.array([1200.0, -700.0, 50.0])
    r = np.linalg.norm(src - ELEMENTS, axis=1)
    np.testing.assert_allclose(m.function(s, CTX), (r[1:] - r[0]) / C, rtol=1e-12)
    num = np.empty((3, 4))
    for j in range(4):
        e = np.zeros(4)
        e[j] = 1e-3
        num[:, j] = (m.function(s + e, CTX) - m.function(s - e, CTX)) / 2e-3
    np.testing.assert_allclose(m.jacobian(s, CTX), num, rtol=1e-6, atol=1e-14)
    assert m.ndim_meas == 3 and not any(m.angular)


def _ref_ekf(x, P, z, m):
    H = m.jacobian(x, CTX)
    R = m.covariance()
    S = H @ P @ H.T + R
    K = P @ H.T @ np.linalg.inv(S)
    nu = z - m.function(x, CTX)
    A = np.eye(x.size) - K @ H
    ll = -0.5 * (nu @ np.linalg.solve(S, nu) + np.linalg.slogdet(2 * np.pi * S)[1])
    return x + K @ nu, A @ P @ A.T + K @ R @ K.T, ll


def _ref_ukf(x, P, z, m, U, wm, wc):
    L = np.linalg.cholesky(P)
    X = x + U @ L.T
    Z = np.array([m.function(xi, CTX) for xi in X])
    zp = wm @ Z
    dZ = Z - zp
    S = (dZ * wc[:, None]).T @ dZ + m.covariance()
    Pxz = ((X - x) * wc[:, None]).T @ dZ
    K = Pxz @ np.linalg.inv(S)
    nu = z - zp
    ll = -0.5 * (nu @ np.linalg.solve(S, nu) + np.linalg.slogdet(2 * np.pi * S)[1])
    return x + K @ nu, P - K @ S @ K.T, ll


@pytest.fixture()
def prior():
    x = np.array([1500.0, -500.0, 2.0, -1.0])
    P = np.diag([300.0, 300.0, 1.0, 1.0]) ** 2
    return x, P


def test_ekf_vector_update_matches_numpy(prior):
    x, P = prior
    m = _model()
    z = m.function(np.array([1400.0, -650.0, 0, 0]), CTX) + 1e-5
    s, ll = EKF().update(EKF().initialize(x, P), z, m, CTX)
    xr, Pr, llr = _ref_ekf(x, P, z, m)
    np.testing.assert_allclose(s.x, xr, rtol=1e-9)
    np.testing.assert_allclose(s.P, Pr, rtol=1e-7, atol=1e-9 * np.abs(Pr).max())
    assert ll == pytest.approx(llr, rel=1e-9)
    nu, S = EKF().innovation(EKF().initialize(x, P), z, m, CTX)
    np.testing.assert_allclose(nu, z - m.function(x, CTX))


def test_ukf_vector_update_matches_numpy(prior):
    x, P = prior
    m = _model()
    f = UKF(alpha=1.0, beta=2.0, kappa=0.0)
    z = m.function(np.array([1400.0, -650.0, 0, 0]), CTX) + 1e-5
    s, ll = f.update(f.initialize(x, P), z, m, CTX)
    xr, Pr, llr = _ref_ukf(x, P, z, m, *f.points(4))
    np.testing.assert_allclose(s.x, xr, rtol=1e-9)
    np.testing.assert_allclose(s.P, Pr, rtol=1e-6, atol=1e-9 * np.abs(Pr).max())
    assert ll == pytest.approx(llr, rel=1e-9)
    nu, S = f.innovation(f.initialize(x, P), z, m, CTX)
    # the update's likelihood is N(ν; 0, S) of the gating innovation
    assert ll == pytest.approx(-0.5 * (nu @ np.linalg.solve(S, nu)
                                       + np.linalg.slogdet(2 * np.pi * S)[1]), rel=1e-9)


@pytest.mark.parametrize("name", ["ekf", "ukf", "ckf"])
def test_filters_track_a_target_from_tdoa(name):
    """CV target at ~1.5 km heard by a 4-element array (delay σ 0.1 ms): 40 TDOA updates bring
    the position error from the prior's ~250 m to a few metres, with a consistent
    covariance."""
    rng = np.random.default_rng(12)
    m = _model(1e-4)
    cv = constant_velocity(1e-4)
    f = make_filter(name)
    truth = np.array([1400.0, -650.0, -1.5, 2.0])
    s = f.initialize(np.array([1600.0, -500.0, 0.0, 0.0]), np.diag([300.0, 300, 3, 3]) ** 2)
    Lr = np.linalg.cholesky(m.covariance())
    for _ in range(40):
        truth = truth + np.array([10 * truth[2], 10 * truth[3], 0, 0])
        z = m.function(truth, CTX) + Lr @ rng.standard_normal(3)
        s = f.predict(s, cv, 10.0, CTX)
        s, ll = f.update(s, z, m, CTX)
        assert math.isfinite(ll)
    err = s.x[:2] - truth[:2]
    assert np.hypot(*err) < 10.0
    assert err @ np.linalg.solve(s.P[:2, :2], err) < 13.8  # χ²₂ 99.9 %
