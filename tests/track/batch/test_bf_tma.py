"""Bearings + frequency batch TMA (unknown rest frequency) on the end-fire crossing in a turn:
the frequency rows against finite differences, the fit within its bound, mean NEES over seeds
(dimension 5), and how much the frequencies shrink the bearings-only bound."""

from __future__ import annotations

import numpy as np
import pytest

from arrayproc.track.batch import scenarios as S
from arrayproc.track.batch.bf_tma import (
    doppler_factor,
    range_rate_gradient,
    solve_bearings_frequency,
)
from arrayproc.track.batch.bo_tma import cone_model, solve_cone

C = 1500.0
F0 = 300.0
SIG_A = np.deg2rad(0.5)
SIG_F = 0.05
TRUTH = np.append(S.ENDFIRE_SOURCE, F0)


def _rows(seed: int):
    tr, vel = S.endfire_turn_track()
    rng = np.random.default_rng(seed)
    cone = np.abs(cone_model(TRUTH[:4], tr.time, tr.position, tr.heading)
                  + rng.normal(0, SIG_A, tr.time.size))
    f = F0 * doppler_factor(TRUTH[:4], tr.time, tr.position, vel, C)
    return tr, vel, cone, f + rng.normal(0, SIG_F, f.size)


def test_doppler_factor_and_its_gradient():
    tr, vel = S.endfire_turn_track()
    g = doppler_factor(TRUTH[:4], tr.time, tr.position, vel, C)
    # closed form at t = 0: ownship north at 5 kn, source 3 m/s on 300 at bearing 025
    u = TRUTH[2:4] - vel[0]
    d = TRUTH[:2] - tr.position[0]
    assert g[0] == pytest.approx(1 - (d @ u) / np.hypot(*d) / C, rel=1e-14)
    h = np.array([1e-2, 1e-2, 1e-4, 1e-4])
    fd = np.stack([(doppler_factor(TRUTH[:4] + h[i] * np.eye(4)[i], tr.time, tr.position,
                                   vel, C)
                    - doppler_factor(TRUTH[:4] - h[i] * np.eye(4)[i], tr.time, tr.position,
                                     vel, C)) / (2 * h[i]) for i in range(4)], axis=1)
    np.testing.assert_allclose(fd, -range_rate_gradient(TRUTH[:4], tr.time, tr.position, vel)
                               / C, rtol=1e-6, atol=1e-13)


def test_fit_through_the_crossing_within_3_sigma_and_a_tighter_bound():
    tr, vel, cone, f = _rows(5)
    sol = solve_bearings_frequency(tr.time, cone, f, tr.position, vel, SIG_A, SIG_F,
                                   heading_rad=tr.heading, sound_speed=C, seed=1)
    assert sol.side == "starboard>port" and sol.state.size == 5
    e = sol.state - TRUTH
    assert float(e @ np.linalg.solve(sol.crlb, e)) < 18.2        # χ²(5) at 99.7 %
    bo = solve_cone(tr.time, cone, tr.heading, tr.position, SIG_A, seed=1)
    assert sol.range_sigma < bo.range_sigma


def _nees(n: int) -> tuple[np.ndarray, np.ndarray]:
    out, shrink = [], []
    for k in range(n):
        tr, vel, cone, f = _rows(2000 + k)
        sol = solve_bearings_frequency(tr.time, cone, f, tr.position, vel, SIG_A, SIG_F,
                                       heading_rad=tr.heading, sound_speed=C, seed=k)
        e = sol.state - TRUTH
        out.append(float(e @ np.linalg.solve(sol.crlb, e)))
    return np.array(out), np.array(shrink)


def test_mean_nees_against_the_bound_reduced():
    """10 seeds: mean NEES within [0.5, 2] × 5."""
    nees, _ = _nees(10)
    assert 2.5 <= nees.mean() <= 10.0, nees


@pytest.mark.slow
def test_mean_nees_against_the_bound_50_seeds():
    nees, _ = _nees(50)
    assert 2.5 <= nees.mean() <= 10.0, nees
