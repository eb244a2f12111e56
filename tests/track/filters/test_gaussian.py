"""Gaussian filters and their numba kernels against closed forms and independent numpy
references (L-R paper section IV)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import integrate, stats

from arrayproc.track.crlb import polar_prior_covariance
from arrayproc.track.filters import CKF, EKF, GHF, SRF, UKF, FilterDivergence, make_filter
from arrayproc.track.filters import _kernels as kf
from arrayproc.track.filters.points import (
    cubature_points,
    gauss_hermite_points,
    unscented_points,
)
from arrayproc.track.init import TrackPrior, init_from_bearing
from arrayproc.track.models.bearing import Bearing
from arrayproc.track.models.motion import constant_turn, constant_velocity
from arrayproc.track.state import Context

OWN0 = np.array([100.0, -50.0, 1.5, -1.8])
OWN1 = np.array([190.0, -158.0, 1.2, -2.0])
CTX = Context(OWN1, OWN0)
BEARING = Bearing(sigma_deg=1.5)


def _step(f, model, x, P, z_deg=41.0, predict=True):
    """One predict (60 s) + bearing update of filter ``f``; returns (state, log-likelihood)."""
    s = f.initialize(x, P)
    if predict:
        s = f.predict(s, model, 60.0, CTX)
    return f.update(s, math.radians(z_deg), BEARING, CTX)


# ---------------------------------------------------------------------------- sample points

@pytest.mark.parametrize("pts", [cubature_points(4), unscented_points(4),
                                 unscented_points(5, 0.5, 2.0, 0.0), gauss_hermite_points(4, 3),
                                 gauss_hermite_points(5, 4)])
def test_points_match_standard_normal_moments(pts):
    U, wm, wc = pts
    n = U.shape[1]
    assert wm.sum() == pytest.approx(1.0)
    np.testing.assert_allclose(wm @ U, np.zeros(n), atol=1e-13)
    cov = (U * wc[:, None]).T @ U - (wc.sum() - 1.0) * 0.0
    np.testing.assert_allclose((U * wm[:, None]).T @ U, np.eye(n), atol=1e-12)
    assert cov.shape == (n, n)


def test_gauss_hermite_is_exact_for_fourth_moments():
    U, w, _ = gauss_hermite_points(3, 3)
    assert w @ U[:, 0] ** 4 == pytest.approx(3.0)
    assert w @ (U[:, 0] ** 2 * U[:, 1] ** 2) == pytest.approx(1.0)
    assert U.shape == (27, 3)


# ----------------------------------------------------------------------- numpy references

def _wrap(a):
    return (a + np.pi) % (2 * np.pi) - np.pi


def _ekf_ref(x, P, z, R, T, F, Q, fx):
    x = fx.copy()
    P = F @ P @ F.T + Q
    r2 = x[0] ** 2 + x[1] ** 2
    H = np.zeros(x.size)
    H[:2] = x[1] / r2, -x[0] / r2
    S = H @ P @ H + R
    K = P @ H / S
    nu = _wrap(z - math.atan2(x[0], x[1]))
    x = x + K * nu
    A = np.eye(x.size) - np.outer(K, H)
    P = A @ P @ A.T + R * np.outer(K, K)
    return x, P, -0.5 * (math.log(2 * math.pi * S) + nu * nu / S)


def _sp_ref(x, P, z, R, T, model, U, wm, wc):
    L = np.linalg.cholesky(P)
    X = x + U @ L.T
    Y = np.array([model.function(xi, T, CTX) for xi in X])
    x = wm @ Y
    D = Y - x
    P = D.T @ (wc[:, None] * D) + model.covariance(T)
    L = np.linalg.cholesky(P)
    X = x + U @ L.T
    Z = np.arctan2(X[:, 0], X[:, 1])
    zp = _wrap(Z[0] + wm @ _wrap(Z - Z[0]))
    dz = _wrap(Z - zp)
    S = wc @ dz**2 + R
    Pxz = (X - x).T @ (wc * dz)
    K = Pxz / S
    nu = _wrap(z - zp)
    return x + K * nu, P - np.outer(K, K) * S, -0.5 * (math.log(2 * math.pi * S) + nu**2 / S)


def _state(n):
    rng = np.random.default_rng(n)
    x = np.array([3500.0, 2500.0, -2.5, 1.0, 0.0005])[:n]
    A = rng.standard_normal((n, n)) * np.array([300, 300, 0.5, 0.5, 1e-4])[:n]
    P = A @ A.T + np.diag([1e4, 1e4, 0.1, 0.1, 1e-8][:n])
    return x, P


@pytest.mark.parametrize("model", [constant_velocity(), constant_turn()])
def test_ekf_step_matches_numpy(model):
    x, P = _state(model.ndim)
    f, ll = _step(EKF(), model, x, P)
    xr, Pr, llr = _ekf_ref(x, P, math.radians(41.0), math.radians(1.5) ** 2, 60.0,
                           model.jacobian(x, 60.0, CTX), model.covariance(60.0),
                           model.function(x, 60.0, CTX))
    np.testing.assert_allclose(f.x, xr, rtol=1e-10)
    np.testing.assert_allclose(f.P, Pr, rtol=1e-8, atol=1e-10 * np.abs(Pr).max())
    assert ll == pytest.approx(llr, rel=1e-10)


@pytest.mark.parametrize("cls,kw", [(UKF, {"kappa": 0.0, "beta": 2.0}), (CKF, {}),
                                    (GHF, {"gh_order": 3}),
                                    (GHF, {"gh_order": 4})])
@pytest.mark.parametrize("model", [constant_velocity(), constant_turn()])
def test_sample_point_step_matches_numpy(cls, kw, model):
    x, P = _state(model.ndim)
    filt = cls(**kw)
    f, ll = _step(filt, model, x, P)
    xr, Pr, llr = _sp_ref(x, P, math.radians(41.0), math.radians(1.5) ** 2, 60.0, model,
                          *filt.points(model.ndim))
    np.testing.assert_allclose(f.x, xr, rtol=1e-9)
    np.testing.assert_allclose(f.P, Pr, rtol=1e-7, atol=1e-9 * np.abs(Pr).max())
    assert ll == pytest.approx(llr, rel=1e-9)


# --------------------------------------------------------------------------- shifted Rayleigh

@pytest.mark.parametrize("u", [-40.0, -12.0, -3.5, -3.0, -2.9, -0.5, 0.0, 0.7, 4.0, 25.0])
def test_shifted_rayleigh_moments_by_quadrature(u):
    # p(t) ∝ t exp(−(t − u)²/2) on t ≥ 0, rescaled by exp(u²/2) to stay representable
    dens = lambda t: t * math.exp(-0.5 * t * t + t * u)  # noqa: E731
    hi = max(u, 0.0) + 14.0
    pts = [u] if u > 0 else [min(1.0, 3.0 / abs(u))] if u < 0 else None

    def q(f):
        return integrate.quad(f, 0.0, hi, points=pts, epsabs=0, epsrel=1e-13, limit=400)[0]

    c = q(dens)
    m1 = q(lambda t: t * dens(t)) / c
    m2r = q(lambda t: t * t * dens(t)) / c
    rho, m2 = kf.shifted_rayleigh_moments(u)
    assert rho == pytest.approx(m1, rel=1e-9)
    assert m2 == pytest.approx(m2r, rel=1e-9)


def _srf_ref(x, P, z, sigma):
    """SRF update by brute force: integrate the Gaussian posterior over the range along b."""
    b = np.array([math.sin(z), math.cos(z)])
    Rm = sigma**2 * (x[0] ** 2 + x[1] ** 2 + P[0, 0] + P[1, 1])
    H = np.zeros((2, x.size))
    H[0, 0] = H[1, 1] = 1
    V = H @ P @ H.T + Rm * np.eye(2)
    K = P @ H.T @ np.linalg.inv(V)
    mvn = stats.multivariate_normal(H @ x, V)
    w = lambda s: s * mvn.pdf(s * b)  # noqa: E731  density of s given b (unnormalised)
    r = np.linalg.norm(x[:2])
    hi = r + 20 * math.sqrt(V.trace())
    c = integrate.quad(w, 0, hi, points=[r], limit=200, epsrel=1e-11)[0]
    m1 = integrate.quad(lambda s: s * w(s), 0, hi, points=[r], limit=200, epsrel=1e-11)[0] / c
    m2 = integrate.quad(lambda s: s * s * w(s), 0, hi, points=[r], limit=200,
                        epsrel=1e-11)[0] / c
    xp = x + K @ (m1 * b - H @ x)
    Pp = P - K @ H @ P + (m2 - m1**2) * np.outer(K @ b, K @ b)
    return xp, Pp, math.log(c)


@pytest.mark.parametrize("zdeg", [55.0, 40.0, 70.0])
def test_srf_update_matches_quadrature(zdeg):
    x, P = _state(4)
    f, ll = _step(SRF(likelihood="exact"), constant_velocity(), x, P, zdeg, predict=False)
    xr, Pr, llr = _srf_ref(x, P, math.radians(zdeg), math.radians(1.5))
    np.testing.assert_allclose(f.x, xr, rtol=1e-7)
    np.testing.assert_allclose(f.P, Pr, rtol=1e-6, atol=1e-8 * np.abs(Pr).max())
    assert ll == pytest.approx(llr, abs=1e-7)  # exact = log ∫ s N(s b; Hx, V) ds


def test_srf_exact_likelihood_is_a_density_over_the_bearing():
    x, P = _state(4)

    def p(th):
        xx, PP = x.copy(), P.copy()
        ll, _ = kf.srf_update(xx, PP, th, math.radians(1.5), True)
        return math.exp(ll)

    tot = integrate.quad(p, -math.pi, math.pi, points=[math.atan2(x[0], x[1])], limit=400)[0]
    assert tot == pytest.approx(1.0, rel=1e-8)


def test_srf_cv_prediction_is_exact_linear():
    x, P = _state(4)
    m = constant_velocity()
    f = SRF().predict(SRF().initialize(x, P), m, 60.0, CTX)
    F = m.jacobian(x, 60.0, CTX)
    np.testing.assert_allclose(f.x, m.function(x, 60.0, CTX), rtol=1e-13)
    np.testing.assert_allclose(f.P, F @ P @ F.T + m.covariance(60.0), rtol=1e-12)


# ------------------------------------------------------------------ initialisation, hygiene

def test_initialisation_matches_the_polar_prior_of_crlb_module():
    prior = TrackPrior()
    own = np.array([0.0, 0.0, 1.65, -1.97])
    x, P = init_from_bearing(80.0, own, prior, 4)
    b = math.radians(80.0)
    ref = polar_prior_covariance(b, prior.range_m, math.radians(1.5), prior.sigma_range_m,
                                 prior.speed_mps, b + math.pi, prior.sigma_speed_mps,
                                 math.radians(prior.sigma_course_deg))
    np.testing.assert_allclose(P, ref, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(x[:2], prior.range_m * np.array([math.sin(b), math.cos(b)]))
    tv = x[2:] + own[2:]
    assert math.hypot(*tv) == pytest.approx(prior.speed_mps)
    assert math.degrees(math.atan2(tv[0], tv[1])) % 360 == pytest.approx(260.0)
    x5, P5 = init_from_bearing(80.0, own, prior, 5)
    assert x5[4] == 0 and P5[4, 4] == pytest.approx(math.radians(prior.sigma_turn_deg_s) ** 2)


def test_chol_repair_recovers_or_reports():
    L = np.empty((3, 3))
    P = np.diag([1.0, 1.0, -1e-12])
    assert kf.chol_repair(P, L) == 1
    assert np.all(np.linalg.eigvalsh(P) > 0)
    P = np.array([[1.0, 2.0], [0.0, 1.0]])  # asymmetric: symmetrised then factored
    assert kf.chol_repair(P, np.empty((2, 2))) in (0, 1)
    np.testing.assert_allclose(P, P.T)
    assert kf.chol_repair(np.array([[np.nan, 0.0], [0.0, 1.0]]), np.empty((2, 2))) == -1


def test_filters_raise_instead_of_returning_nan():
    for name in ("ekf", "ukf", "ckf", "ghf", "srf"):
        x, P = _state(4)
        P[0, 0] = np.nan
        with pytest.raises(FilterDivergence):
            _step(make_filter(name), constant_velocity(), x, P, 40.0)


@settings(max_examples=30, deadline=None)
@given(z=st.floats(0, 359.9), r=st.floats(500, 30000), seed=st.integers(0, 1000))
def test_updates_keep_covariance_symmetric_positive_definite(z, r, seed):
    rng = np.random.default_rng(seed)
    for name in ("ekf", "ukf", "ckf", "srf"):
        x, P = init_from_bearing(float(rng.uniform(0, 360)), OWN0, TrackPrior(range_m=r), 4)
        f, _ = _step(make_filter(name), constant_velocity(), x, P, z)
        assert np.all(np.isfinite(f.x))
        np.testing.assert_array_equal(f.P, f.P.T)
        assert np.all(np.linalg.eigvalsh(f.P) > 0)


@pytest.mark.parametrize("u", [-35.0, -8.0, -3.2, -2.5, 0.0, 3.0])
def test_log_phi_plus_u_phi_by_quadrature(u):
    # φ(u) + uΦ(u) = ∫_0^∞ t φ(t − u) dt / 1
    val = integrate.quad(lambda t: t * math.exp(-0.5 * t * t + t * u), 0, 40, epsabs=0,
                         epsrel=1e-13, limit=400, points=[min(1.0, 3 / max(abs(u), 1e-9))])[0]
    ref = math.log(val) - 0.5 * u * u - 0.5 * math.log(2 * math.pi)
    assert kf._log_phi_plus_u_Phi(u) == pytest.approx(ref, rel=1e-11, abs=1e-11)


