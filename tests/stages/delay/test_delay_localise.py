"""ML TDOA localisation: exact recovery, covariance against the CRLB, rejection, fallback."""

from __future__ import annotations

import numpy as np
import pytest

from arrayproc.geo import tdoa
from arrayproc.stages.delay.localise import (
    LocaliseConfig,
    array_rank,
    localise_event,
    solve_direction,
)

EL = np.array([[-0.86, -0.86, -0.67], [-0.86, -0.86, 0.48], [0.86, -0.86, -0.67],
               [0.0, 0.0, 0.0], [-0.86, 0.86, -0.67], [0.86, 0.86, 0.67]])
C = 1484.0
REF = 3


@pytest.mark.parametrize("src", [[1.0, 0.5, -0.3], [-4.0, 7.0, 2.0], [12.0, -15.0, 3.0]])
def test_noise_free_position_recovered(src):
    src = np.array(src)
    tau = tdoa.predicted_delays(src, EL, REF, C)
    sig = np.full(6, 1e-6)
    sol = localise_event(tau, sig, np.ones(6), EL, REF, C)
    assert sol is not None
    np.testing.assert_allclose(sol.position, src, atol=1e-6 * max(1, np.linalg.norm(src)))
    assert sol.n_used == 5
    assert sol.tdoa_rms_s < 1e-12
    crlb = tdoa.crlb(src, EL, REF, C, tdoa.reference_covariance(sig[np.arange(6) != REF]))
    np.testing.assert_allclose(sol.cov, crlb, rtol=1e-6)


def test_monte_carlo_matches_crlb_reduced():
    """Gaussian delays with the common-reference covariance: RMSE within 25 % of the CRLB and
    mean NEES near 3 (80 draws at 6 m)."""
    rng = np.random.default_rng(0)
    src = np.array([4.0, -4.0, 1.0])
    sig = np.full(5, 2e-6)
    Cm = tdoa.reference_covariance(sig)
    Lc = np.linalg.cholesky(Cm)
    tau0 = tdoa.predicted_delays(src, EL, REF, C)
    err, nees = [], []
    for _ in range(80):
        tau = tau0.copy()
        tau[np.arange(6) != REF] += Lc @ rng.standard_normal(5)
        sol = localise_event(tau, np.r_[sig[:3], 0.0, sig[3:]], np.ones(6), EL, REF, C,
                             LocaliseConfig(min_corr=0.0))
        e = sol.position - src
        err.append(e @ e)
        nees.append(e @ np.linalg.solve(sol.cov, e))
    crlb = np.trace(tdoa.crlb(src, EL, REF, C, Cm))
    assert np.sqrt(np.mean(err)) == pytest.approx(np.sqrt(crlb), rel=0.25)
    assert 2.2 < np.mean(nees) < 3.8  # χ²₃ mean over 80 draws: 3 ± 0.55 (2σ)


def test_rejections():
    tau = tdoa.predicted_delays(np.array([3.0, 2.0, 1.0]), EL, REF, C)
    sig = np.full(6, 1e-6)
    corr = np.array([0.9, 0.1, 0.1, 1.0, 0.9, 0.9])
    assert localise_event(tau, sig, corr, EL, REF, C, LocaliseConfig(min_corr=0.5)) is None
    sig_bad = sig.copy()
    sig_bad[[0, 1]] = np.inf
    assert localise_event(tau, sig_bad, np.ones(6), EL, REF, C) is None
    far = tdoa.predicted_delays(np.array([300.0, 0.0, 0.0]), EL, REF, C)
    assert localise_event(far, sig, np.ones(6), EL, REF, C, LocaliseConfig(max_range=50)) is None


def test_cov_scale_by_fit():
    rng = np.random.default_rng(1)
    src = np.array([2.0, 3.0, 0.5])
    tau = tdoa.predicted_delays(src, EL, REF, C) + rng.normal(0, 5e-6, 6) * (np.arange(6) != REF)
    sig = np.full(6, 1e-6)
    a = localise_event(tau, sig, np.ones(6), EL, REF, C, LocaliseConfig(cov_scale="none"))
    b = localise_event(tau, sig, np.ones(6), EL, REF, C, LocaliseConfig(cov_scale="fit"))
    np.testing.assert_allclose(b.cov, a.cov * a.chi2 / 2, rtol=1e-9)


def test_array_rank():
    assert array_rank(EL) == 3
    assert array_rank(EL * [1, 1, 0]) == 2
    line = np.zeros((8, 3))
    line[:, 0] = np.arange(8)
    assert array_rank(line) == 1


def test_direction_planar_array():
    plane = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0.5, -0.5, 0]], float)
    u = np.array([0.48, 0.64, 0.6])
    tau = tdoa.plane_wave_delays(u, plane, 0, C)
    got = solve_direction(tau, np.full(5, 1e-6), np.ones(5), plane, 0, C)
    assert got is not None
    np.testing.assert_allclose(np.abs(got[0]), np.abs(u), atol=1e-6)
    assert got[2] == 4
