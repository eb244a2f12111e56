"""ML correlation time of exponentially correlated residuals (arrayproc.track.batch.correlation):
the O(N) likelihoods against a dense numpy Gaussian likelihood, recovery of a known τ from
simulated AR(1) residuals with a calibrated standard error, invariances, and the compact TMA
refitted with its own τ̂."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from arrayproc.track.batch.compact import compact_bearings
from arrayproc.track.batch.correlation import (
    _profile_white,
    estimate_correlation_time,
    profile_loglik,
    solve_compact_estimated,
)


def ar1(rng, t, sigma, tau):
    """Exact OU samples at times t."""
    e = np.empty(t.size)
    e[0] = sigma * rng.standard_normal()
    for b in range(1, t.size):
        phi = np.exp(-(t[b] - t[b - 1]) / tau)
        e[b] = phi * e[b - 1] + sigma * np.sqrt(1 - phi**2) * rng.standard_normal()
    return e


def dense_profile(t, r, tau, rho=1.0):
    """numpy reference: the Gaussian log-likelihood with C = s² [ρ exp(−|Δ|/τ) + (1−ρ) I],
    s² at its ML value r K⁻¹ r / N."""
    k = rho * np.exp(-np.abs(t[:, None] - t[None, :]) / tau) + (1 - rho) * np.eye(t.size)
    n = t.size
    s2 = r @ np.linalg.solve(k, r) / n
    return -0.5 * n * (np.log(2 * np.pi * s2) + 1) - 0.5 * np.linalg.slogdet(k)[1]


times = st.lists(st.floats(0.1, 5.0), min_size=3, max_size=40).map(
    lambda d: np.cumsum(np.asarray(d)))


@settings(max_examples=60, deadline=None)
@given(times, st.floats(0.2, 200.0), st.integers(0, 10_000))
def test_profile_equals_dense_reference(t, tau, seed):
    r = np.random.default_rng(seed).standard_normal(t.size)
    assert profile_loglik(t, r, tau) == pytest.approx(dense_profile(t, r, tau), rel=1e-8,
                                                      abs=1e-8)


@settings(max_examples=40, deadline=None)
@given(times, st.floats(0.5, 100.0), st.floats(0.05, 0.99), st.integers(0, 10_000))
def test_white_profile_equals_dense_reference(t, tau, rho, seed):
    r = np.random.default_rng(seed).standard_normal(t.size)
    got = _profile_white(tau, rho, np.diff(t), r)[0]
    assert got == pytest.approx(dense_profile(t, r, tau, rho), rel=1e-8, abs=1e-8)


@settings(max_examples=20, deadline=None)
@given(st.floats(0.01, 100.0), st.floats(0.1, 10.0), st.floats(-1e3, 1e3),
       st.integers(0, 1000))
def test_scale_and_time_invariance(k, a, b, seed):
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 200.0, 2.0)
    r = ar1(rng, t, 1.0, 10.0)
    e = estimate_correlation_time(t, r)
    assert estimate_correlation_time(t, k * r).tau_s == pytest.approx(e.tau_s, rel=1e-4)
    assert estimate_correlation_time(a * t + b, r).tau_s == pytest.approx(a * e.tau_s,
                                                                          rel=1e-4)


def test_recovers_tau_with_a_calibrated_error():
    """60 AR(1) series, τ = 20 s every 2 s over 1200 s: the mean τ̂ within 10 %, the spread
    of τ̂ matched by the mean standard error within 30 %, z-scores centred."""
    rng = np.random.default_rng(7)
    t = np.arange(0.0, 1200.0, 2.0)
    est = [estimate_correlation_time(t, ar1(rng, t, 1.3, 20.0)) for _ in range(60)]
    tau = np.array([e.tau_s for e in est])
    se = np.array([e.tau_sigma_s for e in est])
    assert np.mean(tau) == pytest.approx(20.0, rel=0.1)
    assert np.std(tau) / np.mean(se) == pytest.approx(1.0, abs=0.3)
    assert abs(np.mean((tau - 20.0) / se)) < 0.5
    assert np.mean([e.sigma for e in est]) == pytest.approx(1.3, rel=0.1)


def test_white_noise_model_recovers_tau_the_plain_one_misses():
    rng = np.random.default_rng(11)
    t = np.arange(0.0, 1200.0, 2.0)
    plain, mixed, wsig = [], [], []
    for _ in range(20):
        r = ar1(rng, t, 1.0, 20.0) + rng.standard_normal(t.size)
        plain.append(estimate_correlation_time(t, r).tau_s)
        e = estimate_correlation_time(t, r, white=True)
        mixed.append(e.tau_s)
        wsig.append(e.white_sigma)
    assert np.median(plain) < 6.0  # white noise makes the exponential fit alone short
    assert np.median(mixed) == pytest.approx(20.0, rel=0.25)
    assert np.median(wsig) == pytest.approx(1.0, rel=0.15)


def test_white_residuals_give_the_lower_bound():
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 400.0, 2.0)
    e = estimate_correlation_time(t, rng.standard_normal(t.size))
    assert e.tau_s < 1.5


def test_compact_refit_with_its_own_tau():
    """A vessel at 7.3 m/s, 700 m CPA, bearings every 2 s with OU errors (1°, τ = 20 s): τ̂
    within 3 standard errors of 20 s, the solution's CPA position within 3 CRLB σ."""
    rng = np.random.default_rng(5)
    v, g = 7.3, np.deg2rad(90.0)
    t = np.arange(0.0, 400.0, 2.0)
    q = np.array([-v * 200.0, 700.0, g])
    y = compact_bearings(q, v, t, np.zeros(2)) + np.deg2rad(ar1(rng, t, 1.0, 20.0))
    sol = solve_compact_estimated(t, y, np.zeros(2), None, speed_mps=v, sigma_speed_mps=1.5,
                                  max_range_m=3000.0, n_grid=120, n_headings=72)
    assert abs(sol.tau_s - 20.0) < 3 * sol.tau_sigma_s
    assert 0 < sol.tau_sigma_s < 20.0
    f = np.eye(4)
    f[0, 2] = f[1, 3] = 200.0
    x = f @ sol.state
    p = (f @ sol.crlb @ f.T)[:2, :2]
    e = x[:2] - np.array([0.0, 700.0])
    assert float(np.sqrt(e @ np.linalg.solve(p, e))) < 3.0


def dense_restricted(t, r, g, tau, rho=1.0):
    """numpy reference of eq. (C5): REML of residuals r with the fit's Jacobian g."""
    k = rho * np.exp(-np.abs(t[:, None] - t[None, :]) / tau) + (1 - rho) * np.eye(t.size)
    ki = np.linalg.inv(k)
    gkg = g.T @ ki @ g
    proj = ki - ki @ g @ np.linalg.solve(gkg, g.T @ ki)
    n, p = g.shape
    s2 = r @ proj @ r / (n - p)
    return (-0.5 * (n - p) * (np.log(2 * np.pi * s2) + 1) - 0.5 * np.linalg.slogdet(k)[1]
            - 0.5 * np.linalg.slogdet(gkg)[1])


@settings(max_examples=30, deadline=None)
@given(times, st.floats(0.5, 100.0), st.floats(0.05, 1.0), st.integers(0, 10_000))
def test_restricted_likelihood_equals_dense_reference(t, tau, rho, seed):
    # assume, not times.filter: the oldest Hypothesis admitted filters numpy arrays through
    # np.asfarray, which numpy 2.0 removed
    assume(t.size >= 8)
    from arrayproc.track.batch.correlation import _loglik

    rng = np.random.default_rng(seed)
    r = rng.standard_normal(t.size)
    g = np.column_stack([np.ones(t.size), t, np.sin(t / 7.0)])
    got = _loglik(tau, rho, np.diff(t), r, g)[0]
    assert got == pytest.approx(dense_restricted(t, r, g, tau, rho), rel=1e-7, abs=1e-7)


def test_restricted_likelihood_removes_the_fit_bias():
    """Residuals of a cubic fitted to AR(1) errors (τ = 20 s over 330 s, 40 series): the
    plain ML τ̂ is biased low, the restricted one's median lies within 15 % of τ."""
    rng = np.random.default_rng(21)
    t = np.arange(0.0, 330.0, 2.048)
    g = np.vander((t - t.mean()) / np.ptp(t), 4)
    plain, reml = [], []
    for _ in range(40):
        e = ar1(rng, t, 1.0, 20.0)
        r = e - g @ np.linalg.lstsq(g, e, rcond=None)[0]
        plain.append(estimate_correlation_time(t, r).tau_s)
        reml.append(estimate_correlation_time(t, r, design=g).tau_s)
    assert np.median(plain) < 17.0
    assert np.median(reml) == pytest.approx(20.0, rel=0.15)
    assert np.median(reml) > np.median(plain) + 2.0
