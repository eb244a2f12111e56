"""Motion models (L-R paper eqs. (1)-(6)) against closed forms; bearing conventions
(eqs. (7)-(8))."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from arrayproc.track.models.bearing import bearing_deg, port_starboard
from arrayproc.track.models.mirrored_bearing import mirror_bearing_deg
from arrayproc.track.models.motion import (
    Q1_PAPER,
    Q2_PAPER,
    constant_turn,
    constant_velocity,
)
from arrayproc.track.state import Context

OWN0 = np.array([100.0, -50.0, 1.5, -1.8])
OWN1 = np.array([190.0, -158.0, 1.2, -2.0])
CTX = Context(OWN1, OWN0)


# ---------------------------------------------------------------------------------- models

def _ct_abs_reference(X, T):
    """Eq. (5) as a matrix on the absolute 5-state."""
    psi = X[4]
    s, c = math.sin(psi * T), math.cos(psi * T)
    F = np.array([[1, 0, s / psi, -(1 - c) / psi, 0], [0, 1, (1 - c) / psi, s / psi, 0],
                  [0, 0, c, -s, 0], [0, 0, s, c, 0], [0, 0, 0, 0, 1]])
    return F @ X, F


def test_cv_transition_is_eqs_2_3():
    m = constant_velocity()
    x = np.array([4000.0, 900.0, -2.0, 0.5])
    T = 60.0
    F = np.block([[np.eye(2), T * np.eye(2)], [np.zeros((2, 2)), np.eye(2)]])
    u = np.array([OWN1[0] - OWN0[0] - T * OWN0[2], OWN1[1] - OWN0[1] - T * OWN0[3],
                  OWN1[2] - OWN0[2], OWN1[3] - OWN0[3]])  # eq. (3)
    np.testing.assert_allclose(m.function(x, T, CTX), F @ x - u, rtol=1e-13)
    np.testing.assert_allclose(m.jacobian(x, T, CTX), F)


def test_ct_transition_is_eq_5_with_its_input_vector():
    m = constant_turn()
    x = np.array([4000.0, 900.0, -2.0, 0.5, 0.001])
    T = 60.0
    _, F = _ct_abs_reference(np.r_[x[:4] + OWN0, x[4]], T)
    psi = x[4]
    s, c = math.sin(psi * T), math.cos(psi * T)
    vx, vy = OWN0[2], OWN0[3]
    u = np.array([OWN1[0] - OWN0[0] - s / psi * vx + (1 - c) / psi * vy,
                  OWN1[1] - OWN0[1] - (1 - c) / psi * vx - s / psi * vy,
                  OWN1[2] - c * vx + s * vy, OWN1[3] - s * vx - c * vy, 0.0])  # eq. (5) input
    np.testing.assert_allclose(m.function(x, T, CTX), F @ x - u, rtol=1e-12)


def test_ct_tends_to_cv_at_zero_turn_rate():
    x5 = np.array([4000.0, 900.0, -2.0, 0.5, 0.0])
    a = constant_turn().function(x5, 60.0, CTX)
    b = constant_velocity().function(x5[:4], 60.0, CTX)
    np.testing.assert_allclose(a[:4], b, rtol=1e-13)
    x5[4] = 1e-12
    np.testing.assert_allclose(constant_turn().function(x5, 60.0, CTX)[:4], b,
                               rtol=1e-10)


@settings(max_examples=40, deadline=None)
@given(psi=st.floats(-0.01, 0.01), vx=st.floats(-5, 5), vy=st.floats(-5, 5))
def test_ct_jacobian_matches_finite_differences(psi, vx, vy):
    m = constant_turn()
    x = np.array([3000.0, -2000.0, vx, vy, psi])
    J = m.jacobian(x, 60.0, CTX)
    num = np.empty((5, 5))
    for j in range(5):
        h = 1e-6 if j == 4 else 1e-3
        e = np.zeros(5)
        e[j] = h
        num[:, j] = (m.function(x + e, 60.0, CTX) - m.function(x - e, 60.0, CTX)) / (2 * h)
    np.testing.assert_allclose(J, num, rtol=1e-5, atol=1e-6)


def test_process_noise_eqs_4_and_6():
    T = 60.0
    Q = constant_velocity().covariance(T)
    ref = Q1_PAPER * np.block([[T**3 / 3 * np.eye(2), T**2 / 2 * np.eye(2)],
                               [T**2 / 2 * np.eye(2), T * np.eye(2)]])
    np.testing.assert_allclose(Q, ref)
    Q5 = constant_turn().covariance(T)
    np.testing.assert_allclose(Q5[:4, :4], ref)
    assert Q5[4, 4] == pytest.approx(Q2_PAPER * T)
    # unit conversion of the paper's intensities
    assert Q1_PAPER == pytest.approx(1.944e-6 * 1e6 / 216000.0)


def test_bearing_and_mirror_conventions():
    assert bearing_deg(np.array([1.0, 0.0])) == pytest.approx(90.0)  # east
    assert bearing_deg(np.array([0.0, -1.0])) == pytest.approx(180.0)
    assert bearing_deg(np.array([-1.0, 1.0])) == pytest.approx(315.0)
    assert mirror_bearing_deg(100.0, 140.0) == pytest.approx(180.0)  # eq. (8): 2h − θ
    assert mirror_bearing_deg(350.0, 10.0) == pytest.approx(30.0)
    port, stbd, right = port_starboard(np.deg2rad([100.0, 170.0]), np.deg2rad(140.0))
    np.testing.assert_allclose(np.rad2deg(port) % 360, [100.0, 110.0])
    np.testing.assert_allclose(np.rad2deg(stbd) % 360, [180.0, 170.0])
    assert list(right) == [False, True]




@pytest.mark.parametrize("case", [1, 2])
def test_scenario_truth_follows_the_filter_models(case):
    """The section-V truth (built with kinematics.Trajectory) obeys eq. (1) with eqs. (2)-(3)
    (Case I) or eq. (5) (Case II) exactly: the relative model and the trajectories agree."""
    from arrayproc.evaluate.montecarlo import LRScenario

    scn = LRScenario(case=case)
    g = scn.geometry()
    m = constant_velocity() if case == 1 else constant_turn()
    for k in range(1, g["times"].size):
        pred = m.function(g["rel"][k - 1], 60.0, Context(g["own"][k], g["own"][k - 1]))
        np.testing.assert_allclose(pred, g["rel"][k], rtol=1e-9, atol=1e-7)
