"""Bearings + frequency TMA under errors correlated in time (``correlated=True``): the
whitener against the dense covariance, and the NEES against the bound on Monte Carlo runs
with exponentially correlated plus white errors and with white errors alone."""

from __future__ import annotations

import numpy as np
import pytest

from arrayproc.track.batch.bf_tma import doppler_factor, solve_bearings_frequency
from arrayproc.track.batch.bo_tma import bearing_model
from arrayproc.track.batch.correlation import CorrelationEstimate, correlated_whitener

TRUTH = np.array([2000.0, 1000.0, 0.0, 3.0, 300.0])
T = np.arange(0.0, 600.0, 2.0)
OBS = np.stack([np.where(T < 300, 0, 3 * (T - 300)), np.minimum(T, 300) * 3.0], 1)
VEL = np.stack([np.where(T < 300, 0.0, 3.0), np.where(T < 300, 3.0, 0.0)], 1)


def test_whitener_is_the_inverse_square_root_of_the_covariance():
    """WᵀW = K⁻¹ for K = σ² exp(−|Δt|/τ) + σ_w² I on irregular times (relative 1e-9)."""
    rng = np.random.default_rng(0)
    t = np.cumsum(rng.uniform(0.5, 4.0, 60))
    est = CorrelationEstimate(tau_s=12.0, tau_sigma_s=1.0, sigma=0.3, loglik=0.0,
                              at_bound=False, white_sigma=0.2)
    w = correlated_whitener(t, est)(np.eye(t.size))
    k = 0.3**2 * np.exp(-np.abs(t[:, None] - t[None, :]) / 12.0) + 0.2**2 * np.eye(t.size)
    kinv = np.linalg.inv(k)
    assert np.allclose(w.T @ w, kinv, rtol=1e-9, atol=1e-9 * np.abs(kinv).max())
    assert np.allclose(np.tril(w), w)                       # causal: lower triangular


def _ou(n: int, tau: float, sigma: float, rng: np.random.Generator) -> np.ndarray:
    """Exponentially correlated errors of std ``sigma`` sampled every 2 s (eq. C1)."""
    phi = np.exp(-2.0 / tau)
    e = np.empty(n)
    e[0] = sigma * rng.standard_normal()
    for i in range(1, n):
        e[i] = phi * e[i - 1] + sigma * np.sqrt(1 - phi**2) * rng.standard_normal()
    return e


def _nees(runs: int, tau: float | None) -> dict[bool, np.ndarray]:
    brg = bearing_model(TRUTH[:4], T, OBS)
    f = TRUTH[4] * doppler_factor(TRUTH[:4], T, OBS, VEL, 1500.0)
    out: dict[bool, list[float]] = {False: [], True: []}
    for seed in range(runs):
        rng = np.random.default_rng(seed)
        white_a, white_f = rng.standard_normal(T.size), rng.standard_normal(T.size)
        if tau is None:
            b, ff = brg + np.deg2rad(0.3) * white_a, f + 0.02 * white_f
        else:
            b = brg + _ou(T.size, tau, np.deg2rad(0.3), rng) + np.deg2rad(0.1) * white_a
            ff = f + _ou(T.size, tau, 0.02, rng) + 0.01 * white_f
        for corr in (False, True):
            s = solve_bearings_frequency(T, b, ff, OBS, VEL, None, None, seed=1,
                                         correlated=corr)
            e = s.state - TRUTH
            out[corr].append(float(e @ np.linalg.solve(s.crlb, e)))
    return {k: np.asarray(v) for k, v in out.items()}


@pytest.mark.parametrize("runs", [pytest.param(12, id="reduced"),
                                  pytest.param(50, id="full", marks=pytest.mark.slow)])
def test_correlated_errors_nees_at_the_bound(runs):
    """Errors with a 30 s correlation time (15 rows) plus white noise: the white fit's bound
    is far too small (mean NEES over 4 × the dimension), the generalised least-squares fit's
    is at it (mean NEES within [0.5, 2] × 5)."""
    n = _nees(runs, 30.0)
    assert n[False].mean() > 4 * 5
    assert 0.5 * 5 <= n[True].mean() <= 2 * 5, n[True]


@pytest.mark.parametrize("runs", [pytest.param(12, id="reduced"),
                                  pytest.param(50, id="full", marks=pytest.mark.slow)])
def test_white_errors_keep_their_bound_with_the_correlated_fit(runs):
    """White errors: the correlated model finds no correlation to speak of, and both fits'
    mean NEES stay within [0.5, 2] × 5."""
    n = _nees(runs, None)
    for corr in (False, True):
        assert 0.5 * 5 <= n[corr].mean() <= 2 * 5, (corr, n[corr])
