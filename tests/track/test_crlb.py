"""Bearings-only CRLB (zero process noise) against independent numpy references."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from arrayproc.geo.kinematics import KNOT, Trajectory
from arrayproc.track.crlb import (
    bearings_only_crlb,
    cv_transition,
    polar_prior_covariance,
    position_rmse_bound,
)


def _manoeuvring_observer(times):
    traj = Trajectory.from_legs([0.0, 0.0], [
        {"course": 140.0, "speed": 5 * KNOT, "duration": 780.0},
        {"course": 20.0, "speed": 5 * KNOT, "duration": 1020.0, "turn_rate": 0.5},
    ])
    return traj.state(times)[0]


def _bearings(x0, times, obs):
    """Bearing sequence as an explicit function of the initial state (the model, eq. (9))."""
    px = x0[0] + (times - times[0]) * x0[2]
    py = x0[1] + (times - times[0]) * x0[3]
    return np.arctan2(px - obs[:, 0], py - obs[:, 1])


def _reference_numerical(x0, times, obs, sigma, prior=None):
    """FIM of x0 by central-difference Jacobian of the bearing sequence; no closed forms."""
    eps = np.array([1e-2, 1e-2, 1e-5, 1e-5])
    jac = np.empty((times.size, 4))
    for i in range(4):
        dp = np.zeros(4)
        dp[i] = eps[i]
        d = _bearings(x0 + dp, times, obs) - _bearings(x0 - dp, times, obs)
        jac[:, i] = np.angle(np.exp(1j * d)) / (2 * eps[i])
    out = np.full((times.size, 4, 4), np.nan)
    for k in range(times.size):
        j = jac[: k + 1].T @ jac[: k + 1] / sigma**2
        if prior is not None:
            j = j + prior
        dg = np.diag(j)
        if np.any(dg <= 0):
            continue
        sv = np.linalg.svd(j / np.sqrt(np.outer(dg, dg)), compute_uv=False)
        if sv[-1] < 1e-12 * sv[0]:       # unobservable (e.g. before the observer manoeuvres)
            continue
        phi = np.eye(4)
        phi[0, 2] = phi[1, 3] = times[k] - times[0]
        out[k] = phi @ np.linalg.inv(j) @ phi.T
    return out


def _reference_ristic_recursion(x0, times, obs, sigma, prior):
    """Ristic et al. 2003 ch. 4.3.3 recursion J_{k+1} = F^-T J_k F^-1 + H^T H / σ²."""
    out = np.empty((times.size, 4, 4))
    x = x0.astype(float).copy()
    j = prior.copy()
    for k in range(times.size):
        if k > 0:
            f = np.eye(4)
            f[0, 2] = f[1, 3] = times[k] - times[k - 1]
            x = f @ x
            fi = np.linalg.inv(f)
            j = fi.T @ j @ fi
        dx, dy = x[0] - obs[k, 0], x[1] - obs[k, 1]
        h = np.array([dy, -dx, 0, 0]) / (dx * dx + dy * dy)
        j = j + np.outer(h, h) / sigma**2
        out[k] = np.linalg.inv(j)
    return out


X0 = np.array([5000.0, 800.0, *(5 * KNOT * np.array([np.sin(np.deg2rad(-140)),
                                                      np.cos(np.deg2rad(-140))]))])


def test_matches_numerical_jacobian_reference():
    times = np.arange(0.0, 1800.0 + 1, 60.0)
    obs = _manoeuvring_observer(times)
    sigma = np.deg2rad(1.5)
    ours = bearings_only_crlb(X0, times, obs, sigma)
    ref = _reference_numerical(X0, times, obs, sigma)
    valid = ~np.isnan(ref[:, 0, 0])
    # straight-leg BOT is unobservable: the bound exists only once the turn (13 min) begins
    assert not valid[times <= 780.0].any() and valid[times > 780.0].all()
    np.testing.assert_array_equal(np.isnan(ours[:, 0, 0]), ~valid)
    np.testing.assert_allclose(ours[valid], ref[valid], rtol=1e-5, atol=1e-9)


def test_matches_ristic_recursion_with_prior():
    times = np.arange(0.0, 1800.0 + 1, 60.0)
    obs = _manoeuvring_observer(times)
    sigma = np.deg2rad(1.5)
    p0 = polar_prior_covariance(np.arctan2(5000, 800), 10e3, sigma, 2e3, 3 * KNOT,
                                np.arctan2(5000, 800) + np.pi, 2 * KNOT, np.pi / np.sqrt(12))
    prior = np.linalg.inv(p0)
    ours = bearings_only_crlb(X0, times, obs, sigma, prior_info=prior)
    ref = _reference_ristic_recursion(X0, times, obs, sigma, prior)
    np.testing.assert_allclose(ours, ref, rtol=1e-7, atol=1e-9)
    # the bound at t0 is the prior covariance itself plus one bearing
    assert position_rmse_bound(ours)[0] < np.sqrt(p0[0, 0] + p0[1, 1])


def test_static_observer_single_bearing_is_singular_without_prior():
    times = np.array([0.0])
    ours = bearings_only_crlb(X0, times, np.zeros((1, 2)), 0.01)
    assert np.isnan(ours).all()


def test_cv_transition_composes():
    a, b = cv_transition(30.0), cv_transition(45.0)
    np.testing.assert_allclose(a @ b, cv_transition(75.0))


@settings(max_examples=30, deadline=None)
@given(st.floats(-20e3, 20e3), st.floats(-20e3, 20e3), st.floats(-8, 8), st.floats(-8, 8),
       st.floats(0.1, 5.0))
def test_more_bearings_never_loosen_the_bound(x, y, vx, vy, sigma_deg):
    """Information only accumulates: with a prior, tr(CRLB mapped to t0) is non-increasing."""
    x0 = np.array([x, y, vx, vy])
    times = np.arange(0.0, 600.0 + 1, 60.0)
    obs = np.stack([2.0 * times, np.zeros_like(times)], axis=1)
    d = x0[:2] - obs[0]
    if np.hypot(*d) < 200 or np.any(np.hypot(x + vx * times - obs[:, 0],
                                             y + vy * times - obs[:, 1]) < 200):
        return
    prior = np.diag([1e-8, 1e-8, 1e-2, 1e-2])
    c = bearings_only_crlb(x0, times, obs, np.deg2rad(sigma_deg), prior_info=prior)
    inv_phi = np.linalg.inv(cv_transition(times))
    back = inv_phi @ c @ np.swapaxes(inv_phi, -1, -2)       # bound on x0 after k bearings
    tr = np.trace(back, axis1=1, axis2=2)
    assert np.all(np.diff(tr) <= 1e-9 * tr[:-1] + 1e-12)
