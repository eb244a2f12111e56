"""TDOA model (thesis eq. (3.25) in 3-D), its Jacobian and Fisher information (eq. (C.8))."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from arrayproc.geo import tdoa

EL = np.array([[-0.86, -0.86, -0.67], [-0.86, -0.86, 0.48], [0.86, -0.86, -0.67],
               [0.0, 0.0, 0.0], [-0.86, 0.86, -0.67], [0.86, 0.86, 0.67]])
C = 1484.0


def test_delays_by_hand():
    src = np.array([3.0, 4.0, 0.0])
    el = np.array([[0.0, 0.0, 0.0], [3.0, 0.0, 0.0]])
    t = tdoa.predicted_delays(src, el, 0, C)
    assert t[0] == 0
    assert t[1] == pytest.approx((4.0 - 5.0) / C)
    many = tdoa.predicted_delays(np.stack([src, src]), el, 1, C)
    assert many.shape == (2, 2) and many[1, 1] == 0


@settings(max_examples=40, deadline=None)
@given(st.floats(-30, 30), st.floats(-30, 30), st.floats(-10, 10), st.integers(0, 5))
def test_jacobian_matches_finite_differences(x, y, z, ref):
    s = np.array([x, y, z])
    if np.min(np.linalg.norm(EL - s, axis=1)) < 0.5:
        return
    J = tdoa.jacobian(s, EL, ref, C)
    h = 1e-5
    num = np.stack([(tdoa.predicted_delays(s + h * e, EL, ref, C)
                     - tdoa.predicted_delays(s - h * e, EL, ref, C)) / (2 * h)
                    for e in np.eye(3)], axis=1)
    np.testing.assert_allclose(J, num, atol=1e-9 / C)
    assert np.all(J[ref] == 0)


def test_plane_wave_limit():
    u = np.array([0.6, 0.0, 0.8])
    far = tdoa.predicted_delays(1e6 * u, EL, 3, C)
    np.testing.assert_allclose(tdoa.plane_wave_delays(u, EL, 3, C), far, atol=1e-9)


def test_reference_covariance_equal_snr():
    s = np.full(4, 2e-6)
    Cm = tdoa.reference_covariance(s)
    np.testing.assert_allclose(np.diag(Cm), s**2)
    np.testing.assert_allclose(Cm[0, 1], 0.5 * s[0] ** 2)
    assert np.all(np.linalg.eigvalsh(Cm) > 0)


def test_fisher_is_sum_of_outer_products_for_diagonal_noise():
    src = np.array([5.0, -3.0, 1.0])
    sig = np.array([1e-6, 2e-6, 1.5e-6, 3e-6, 1e-6])
    F = tdoa.fisher_information(src, EL, 3, C, sig)
    H = np.delete(tdoa.jacobian(src, EL, 3, C), 3, axis=0)
    ref = sum(np.outer(h, h) / s**2 for h, s in zip(H, sig))
    np.testing.assert_allclose(F, ref, rtol=1e-12)
    np.testing.assert_allclose(tdoa.crlb(src, EL, 3, C, sig) @ F, np.eye(3), atol=1e-8)


def test_crlb_grows_with_range():
    """Range error of a compact array grows about as r² (bearing-spread of the delays)."""
    sig = np.full(5, 1e-6)
    u = np.array([0.6, 0.8, 0.0])
    tr = [np.trace(tdoa.crlb(r * u, EL, 3, C, tdoa.reference_covariance(sig)))
          for r in (5.0, 10.0, 20.0)]
    assert tr[0] < tr[1] < tr[2]
    assert tr[2] / tr[1] == pytest.approx(16.0, rel=0.3)
