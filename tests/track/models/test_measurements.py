"""Measurement models against their equations: bearing (L-R paper eq. (7)), mirrored bearing
(eq. (8)), bearing + level (SPL paper eqs. (12), (16), (31)-(33)); kernels against numpy."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from arrayproc.acoustics.source_level import SourceLevelModel, received_level
from arrayproc.acoustics.tl import load_default_table
from arrayproc.geo.angles import wrap_pi
from arrayproc.track.models.base import MeasurementModel
from arrayproc.track.models.bearing import Bearing
from arrayproc.track.models.level_bearing import LevelBearing
from arrayproc.track.models.mirrored_bearing import MirroredBearing
from arrayproc.track.state import Context
from tests._tolerance import assert_libm_close

OWN = np.array([100.0, -50.0, 1.5, -1.8])
CTX = Context(OWN, heading=math.radians(140.0))


@pytest.fixture(scope="module")
def level_model():
    return LevelBearing(sigma_deg=1.5, sigma_level_db=4.0, tl_table=load_default_table())


def _numjac(f, x, h, angular=(True,)):
    """Central differences; angular outputs differenced on the circle."""
    J = []
    ang = np.array(angular)
    for j in range(x.size):
        e = np.zeros(x.size)
        e[j] = h[j]
        d = f(x + e) - f(x - e)
        J.append(np.where(ang, wrap_pi(d), d) / (2 * h[j]))
    return np.array(J).T


@settings(max_examples=40, deadline=None)
@given(x=st.floats(-9e3, 9e3), y=st.floats(-9e3, 9e3))
def test_bearing_is_eq_7_and_its_jacobian(x, y):
    if math.hypot(x, y) < 100:
        return
    m = Bearing(sigma_deg=1.5)
    s = np.array([x, y, 1.0, -2.0])
    # numba's atan2 against CPython's: each from the libm it was linked with (LIBM_ULP)
    assert_libm_close(m.function(s, CTX)[0], math.atan2(x, y))
    H = m.jacobian(s, CTX)
    num = _numjac(lambda v: m.function(v, CTX), s, np.array([1e-3, 1e-3, 1e-3, 1e-3]))
    np.testing.assert_allclose(H, num, rtol=1e-6, atol=1e-12)
    assert m.covariance()[0, 0] == pytest.approx(math.radians(1.5) ** 2)


def test_mirrored_bearing_is_eq_8():
    m = MirroredBearing(sigma_deg=1.5)
    s = np.array([3000.0, 1000.0, 1.0, -2.0])
    theta = math.atan2(3000.0, 1000.0)
    assert m.function(s, CTX)[0] == pytest.approx(float(wrap_pi(2 * CTX.heading - theta)))
    np.testing.assert_allclose(m.jacobian(s, CTX), -Bearing().jacobian(s, CTX))
    # the ghost of the ghost is the truth: as_bearing maps z back to γ(X)
    assert m.as_bearing(m.function(s, CTX), CTX) == pytest.approx(theta, abs=1e-12)
    # its particle likelihood is the bearing likelihood of the un-mirrored value
    rel = np.random.default_rng(1).normal([3000, 1000, 1, -2], [200, 200, 1, 1], (50, 4))
    a, b = np.empty(50), np.empty(50)
    m.loglik_particles(rel, m.function(s, CTX), CTX, a)
    Bearing(sigma_deg=1.5).loglik_particles(rel, np.array([theta]), CTX, b)
    np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-12)


def test_residual_wraps_angles_only(level_model):
    d = level_model.residual(np.array([math.pi - 0.01, 100.0]), np.array([-math.pi + 0.01, 40.0]))
    np.testing.assert_allclose(d, [-0.02, 60.0], atol=1e-12)


def test_level_bearing_is_eqs_12_and_16(level_model):
    tab = load_default_table()
    X = np.array([[4000.0, 800.0, -2.0, 0.5], [9000.0, -3000.0, 1.0, 3.0],
                  [150.0, 90.0, 0.0, 0.0]])
    Z = np.empty((3, 2))
    level_model.function_points(X, CTX, Z)
    # numba's libm atan2 against numpy's (SIMD loops on AVX-512 CPUs): a few ulps (LIBM_ULP)
    assert_libm_close(Z[:, 0], np.arctan2(X[:, 0], X[:, 1]))
    absx = X.copy()
    absx[:, :2] += OWN[:2]
    absx[:, 2:] += OWN[2:]
    ref = received_level(absx, np.broadcast_to(OWN[:2], (3, 2)),
                         lambda r: tab(r, 5.0, 300.0), SourceLevelModel(170.0, 53.0, 5.14))
    np.testing.assert_allclose(Z[:, 1], ref, atol=0.05)  # TL: linear vs the table's interpolant


def test_level_bearing_jacobian_matches_finite_differences(level_model):
    s = np.array([4123.0, 817.0, -2.1, 0.4])
    H = level_model.jacobian(s, CTX)
    num = _numjac(lambda v: level_model.function(v, CTX), s, np.array([0.5, 0.5, 1e-4, 1e-4]),
                  (True, False))
    np.testing.assert_allclose(H, num, rtol=1e-4, atol=1e-9)


def test_level_bearing_loglik_kernel_matches_generic_gaussian(level_model):
    """The particle kernel (eqs. (31)-(33)) equals the base class's generic Gaussian
    log-likelihood of the same model, constant included."""
    rng = np.random.default_rng(3)
    rel = rng.normal([4000, 800, -2, 0.5], [300, 300, 1, 1], (200, 4))
    z = np.array([0.4, 95.0])
    a, b = np.empty(200), np.empty(200)
    level_model.loglik_particles(rel, z, CTX, a)
    MeasurementModel.loglik_particles(level_model, rel, z, CTX, b)
    np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-9)
    assert level_model.loglik_norm() == pytest.approx(
        MeasurementModel.loglik_norm(level_model), rel=1e-12)


def test_bearing_loglik_kernel_matches_generic_gaussian():
    m = Bearing(sigma_deg=2.0)
    rel = np.random.default_rng(4).normal([-3000, -100, 0, 0], [500, 500, 1, 1], (100, 4))
    z = np.array([3.1])  # near the ±π cut
    a, b = np.empty(100), np.empty(100)
    m.loglik_particles(rel, z, CTX, a)
    MeasurementModel.loglik_particles(m, rel, z, CTX, b)
    np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-12)
