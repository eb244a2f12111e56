"""The whole-population differential evolution (arrayproc.track.batch.evolution): its partner
draws, determinism, convergence to known minima, and agreement with scipy's solver on a TD-TMA
problem."""

from __future__ import annotations

import numpy as np
from scipy.optimize import differential_evolution

from arrayproc.track.batch import scenarios as S
from arrayproc.track.batch.evolution import _partners, evolve
from arrayproc.track.batch.td_tma import delay_model, solve_delays


def test_partners_distinct_and_uniform():
    rng = np.random.default_rng(0)
    m = 16
    counts = np.zeros((m, m), int)
    for _ in range(4000):
        r1, r2 = _partners(rng, m)
        i = np.arange(m)
        assert np.all(r1 != i) and np.all(r2 != i) and np.all(r2 != r1)
        assert r1.min() >= 0 and r2.max() < m
        counts[i, r2] += 1
    # marginally r2 is uniform over the m - 1 members other than i (r1 uniform, r2 uniform
    # over the m - 2 left): 4000 / 15 per off-diagonal cell, binomial sd ~ 16; 5 sd bound
    off = counts[~np.eye(m, dtype=bool)]
    assert np.all(np.diag(counts) == 0)
    assert np.max(np.abs(off - 4000 / (m - 1))) < 5 * np.sqrt(4000 / (m - 1))


def _rosen(q):
    return 100 * (q[1] - q[0] ** 2) ** 2 + (1 - q[0]) ** 2


def test_evolve_finds_rosenbrock_minimum_and_is_deterministic():
    a = evolve(_rosen, [(-3, 3), (-3, 3)], seed=4, popsize=20, tol=1e-10)
    b = evolve(_rosen, [(-3, 3), (-3, 3)], seed=4, popsize=20, tol=1e-10)
    np.testing.assert_allclose(a.x, [1.0, 1.0], atol=1e-3)
    assert a.converged and a.x.tobytes() == b.x.tobytes() and a.nfev == b.nfev
    assert a.nfev == 64 * (a.nit + 1)   # 2 x 20 rounded up to the Sobol power of two


def test_evolve_stays_in_bounds():
    seen = []

    def cost(q):
        seen.append(q.copy())
        return np.sum((q - 10.0) ** 2, axis=0)   # minimum outside the box

    r = evolve(cost, [(-1, 2), (0, 1), (-5, -4)], seed=1, maxiter=30)
    q = np.concatenate(seen, axis=1)
    lo, hi = np.array([-1, 0, -5])[:, None], np.array([2, 1, -4])[:, None]
    assert np.all(q >= lo) and np.all(q <= hi)
    np.testing.assert_allclose(r.x, [2, 1, -4], atol=0.05)


def test_td_solution_agrees_with_scipy_differential_evolution():
    """Same cost, both global steps: the polished states agree to far below the CRLB."""
    tr = S.turn_track(duration=245.0, dt=5.0)
    el = S.line_elements(tr, 32, 0.36)
    x = S.FIG_3_18_SOURCE
    rng = np.random.default_rng(2)
    y = delay_model(x, tr.time, el, 0, 1500.0) + rng.normal(0, 1e-4, (tr.time.size, 32))
    ours = solve_delays(tr.time, y, el, 1e-4, heading_rad=tr.heading, seed=3)

    import inspect

    import arrayproc.track.batch.result as R
    # scipy >= 1.15 takes the seed as ``rng`` (a Generator); older releases as ``seed``
    key = "rng" if "rng" in inspect.signature(differential_evolution).parameters else "seed"

    def scipy_evolve(cost, bounds, seed, popsize, maxiter, tol, mutation, recombination):
        de = differential_evolution(cost, bounds, vectorized=True, updating="deferred",
                                    **{key: seed}, popsize=popsize, maxiter=maxiter, tol=tol,
                                    atol=0.0, polish=False, init="sobol", mutation=mutation,
                                    recombination=recombination)
        return de

    orig = R.evolve
    R.evolve = scipy_evolve
    try:
        ref = solve_delays(tr.time, y, el, 1e-4, heading_rad=tr.heading, seed=3)
    finally:
        R.evolve = orig
    sd = np.sqrt(np.diag(ours.crlb))
    assert np.all(np.abs(ours.state - ref.state) < 1e-3 * sd)
    assert abs(ours.cost - ref.cost) <= 1e-9 * ref.cost
    assert np.hypot(*(ours.state[:2] - x[:2])) < 5 * np.sqrt(np.trace(ours.crlb[:2, :2]))
