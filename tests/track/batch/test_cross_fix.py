"""Cross-fix TMA of two static arrays: FIM, noiseless recovery, Monte Carlo NEES."""
import numpy as np
import pytest
from scipy import stats

from arrayproc.track.batch.bo_tma import bearing_model
from arrayproc.track.batch.cross_fix import solve_cross_fix
from arrayproc.track.batch.fim import bo_fim, bo_jacobian

SITES = np.array([[0.0, 0.0], [800.0, 0.0]])
TRUTH = np.array([-2000.0, 600.0, 7.3, 0.0])   # paper's 7.3 m/s vessel, CPA 600 m


def _rows(dt: float = 5.0, span: float = 540.0):
    t1 = np.arange(0.0, span + 1e-9, dt)
    t = np.concatenate([t1, t1])
    obs = np.repeat(SITES, t1.size, axis=0)
    return t, obs


def test_jacobian_matches_finite_difference():
    t, obs = _rows()
    jac = bo_jacobian(TRUTH, t, obs)
    fd = np.empty_like(jac)
    for k, h in enumerate([1e-3, 1e-3, 1e-5, 1e-5]):
        e = np.zeros(4)
        e[k] = h
        fd[:, k] = (bearing_model(TRUTH + e, t, obs) - bearing_model(TRUTH - e, t, obs)) / (2 * h)
    np.testing.assert_allclose(jac, fd, rtol=1e-5, atol=1e-10)
    sig = np.radians(1.5)
    np.testing.assert_allclose(bo_fim(TRUTH, t, obs, sig), fd.T @ fd / sig**2, rtol=1e-5)


def test_noiseless_recovery():
    t, obs = _rows()
    y = bearing_model(TRUTH, t, obs)
    sol = solve_cross_fix(t, y, obs, np.radians(1.5))
    np.testing.assert_allclose(sol.state, TRUTH, rtol=1e-6, atol=1e-4)


def _nees(n_runs: int, seed: int, sigma_deg: float = 1.5) -> tuple[float, np.ndarray]:
    rng = np.random.default_rng(seed)
    t, obs = _rows()
    sig = np.radians(sigma_deg)
    clean = bearing_model(TRUTH, t, obs)
    crlb = np.linalg.inv(bo_fim(TRUTH, t, obs, sig))
    inv = np.linalg.inv(crlb)
    err = []
    for _ in range(n_runs):
        sol = solve_cross_fix(t, clean + rng.normal(0.0, sig, t.size), obs, sig)
        err.append(sol.state - TRUTH)
    e = np.array(err)
    nees = np.einsum("ri,ij,rj->r", e, inv, e)
    rmse_ratio = np.sqrt(np.mean(e**2, axis=0) / np.diag(crlb))
    return float(nees.mean()), rmse_ratio


def test_reduced_monte_carlo_nees_in_chi2_band():
    n = 60
    mean, ratio = _nees(n, seed=3)
    lo, hi = stats.chi2.ppf([0.005, 0.995], 4 * n) / n
    assert lo < mean < hi, (mean, ratio)


@pytest.mark.slow
def test_full_monte_carlo_nees_in_chi2_band():
    n = 300
    mean, ratio = _nees(n, seed=11)
    lo, hi = stats.chi2.ppf([0.005, 0.995], 4 * n) / n
    assert lo < mean < hi, (mean, ratio)
    assert np.all(ratio < 1.2), ratio


def test_a_distant_start_with_noisy_end_rows_converges():
    """Seed 0's 148th draw of the two-array scenario at CPA 200 m (arrays 500 m apart, σ 2°,
    the target 4.4 km away at the window start, the rays 6° apart): the cross-fixes of the
    single end rows put the start 6.6e7 m away, from where the estimated-σ refit diverged to
    3.3e6 m; the end bearings from a line through the end rows (and each refit started at the
    previous fit) converge."""
    from arrayproc.evaluate.scenarios.compact_paper import DT, DURATION
    from arrayproc.evaluate.scenarios.two_array_fusion import cv_truth
    from arrayproc.track.batch.cross_fix_run import solve_estimated_sigma

    rng = np.random.default_rng(0)
    t1 = np.arange(0.0, DURATION + 1e-9, DT)
    sites = np.array([[0.0, 0.0], [500.0, 0.0]])
    x, sig = cv_truth(200.0), np.deg2rad(2.0)
    for _ in range(148):
        y = np.concatenate([bearing_model(x, t1, np.tile(s, (t1.size, 1)))
                            + rng.normal(0.0, sig, t1.size) for s in sites])
    t, obs = np.concatenate([t1, t1]), np.repeat(sites, t1.size, axis=0)
    bound = np.sqrt(np.diag(np.linalg.inv(bo_fim(x, t, obs, sig))))
    for sol in (solve_cross_fix(t, y, obs, sig),
                solve_estimated_sigma(t, y, obs, np.repeat([0, 1], t1.size), 0.0, DURATION)):
        assert np.all(np.abs(sol.state - x) < 4 * bound), (sol.state - x) / bound
