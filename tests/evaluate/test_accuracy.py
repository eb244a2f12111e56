"""RMSE, NEES and CRLB-ratio helpers against their definitions."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from arrayproc.evaluate.accuracy import crlb_ratio, crlb_rms, nees, nees_band, rmse


def test_rmse_scalar_and_vector():
    e = np.array([3.0, -4.0])
    assert rmse(e) == pytest.approx(np.sqrt(12.5), rel=1e-15)
    e = np.zeros((2, 5, 2))          # runs, time, (x, y)
    e[0, :, 0], e[1, :, 1] = 3.0, 4.0
    assert np.allclose(rmse(e, components=1), np.sqrt((9 + 16) / 2), rtol=1e-15)


def test_nees_is_the_quadratic_form():
    rng = np.random.default_rng(0)
    a = rng.standard_normal((4, 3, 3))
    P = a @ a.transpose(0, 2, 1) + 3 * np.eye(3)
    e = rng.standard_normal((4, 3))
    want = np.array([e[i] @ np.linalg.inv(P[i]) @ e[i] for i in range(4)])
    # solve vs explicit inverse: a few ulps of the condition number
    assert np.allclose(nees(e, P), want, rtol=1e-12)


def test_consistent_gaussian_errors_fall_in_the_nees_band():
    """Errors drawn from the reported covariance: mean NEES n, inside the 95 % band, which
    matches the χ² quantiles to O(1/sqrt(R n))."""
    rng = np.random.default_rng(5)
    n, runs = 3, 2000
    P = np.diag([4.0, 1.0, 0.25])
    e = rng.multivariate_normal(np.zeros(n), P, runs)
    m = nees(e, np.broadcast_to(P, (runs, n, n))).mean()
    lo, hi = nees_band(n, runs)
    assert lo < m < hi
    q = stats.chi2(runs * n).ppf([0.025, 0.975]) / runs
    assert np.allclose([lo, hi], q, rtol=2e-3)
    assert np.isnan(nees_band(3, 0)[0])


def test_crlb_ratio_of_an_efficient_estimator_is_one():
    B = np.array([[4.0, 0.3], [0.3, 9.0]])
    assert crlb_rms(B) == pytest.approx(np.sqrt(13.0), rel=1e-15)
    assert crlb_rms(np.diag([1.0, 4.0, 100.0]), slice(0, 2)) == pytest.approx(np.sqrt(5.0))
    rng = np.random.default_rng(2)
    e = rng.multivariate_normal([0, 0], B, 20000)
    r = crlb_ratio(rmse(e, components=1), crlb_rms(B))
    assert r == pytest.approx(1.0, abs=0.02)
