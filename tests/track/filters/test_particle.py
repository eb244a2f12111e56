"""RPF filter level: configuration, reproducibility, reduced Monte Carlo of the scenarios."""

import numpy as np
import pytest

from arrayproc.acoustics.tl import load_default_table
from arrayproc.errors import ArrayprocError, ConfigError
from arrayproc.evaluate.scenarios import get_scenario
from arrayproc.track.crlb import position_rmse_bound
from arrayproc.track.filters.particle import RegularizedParticleFilter, RPFConfig


@pytest.fixture(scope="module")
def table():
    return load_default_table()


def test_config_errors(table):
    with pytest.raises(ConfigError):
        RegularizedParticleFilter(RPFConfig(use_levels=True, tl_table=None))
    with pytest.raises(ConfigError):
        RegularizedParticleFilter(RPFConfig(use_levels=False, resampling="stratified"))
    with pytest.raises(ConfigError):
        RegularizedParticleFilter(RPFConfig(use_levels=False, n_thr=0.0))
    f = RegularizedParticleFilter(RPFConfig(use_levels=True, tl_table=table))
    with pytest.raises(ConfigError):
        f.run(np.arange(3) * 60.0, np.zeros((3, 2)), np.array([10.0, 11.0, 12.0]))
    with pytest.raises(ConfigError):
        f.run(np.arange(3) * 60.0, np.zeros((3, 2)), [10.0, np.nan, 12.0], [80.0, 80.0, 80.0])
    with pytest.raises(ConfigError):
        get_scenario("zigzag")


def test_scenarios_match_the_paper():
    m = get_scenario("manoeuvring")
    assert m.times.size == 31 and get_scenario("static").times.size == 151
    x0 = m.target_x0()
    assert np.hypot(x0[2], x0[3]) == pytest.approx(5 * 1852 / 3600)
    assert np.degrees(np.arctan2(x0[2], x0[3])) == pytest.approx(-140.0)
    _, vel, course = m.observer.state(np.array([0.0, 779.0, 900.0, 1021.0, 1800.0]))
    np.testing.assert_allclose(course[[0, 1, 3, 4]], [140.0, 140.0, 20.0, 20.0], atol=1e-9)
    assert course[2] == pytest.approx(80.0)               # mid-turn at 30°/min, to port
    np.testing.assert_allclose(np.hypot(vel[:, 0], vel[:, 1]), 5 * 1852 / 3600)
    p = get_scenario("parallel")
    np.testing.assert_allclose(p.observer.state(100.0)[1][0], x0[2:])    # parallel courses
    np.testing.assert_allclose(get_scenario("static").observer_pos()[-1], [0.0, 0.0])


def test_simulation_and_filter_are_seeded(table):
    sc = get_scenario("manoeuvring")
    a = sc.simulate(3, 5, table)
    b = sc.simulate(3, 5, table)
    assert a.bearings_deg.tobytes() == b.bearings_deg.tobytes()
    assert a.levels_db.tobytes() == b.levels_db.tobytes()
    f = RegularizedParticleFilter(RPFConfig(n_particles=500, tl_table=table))
    r1 = f.run(a.times, a.observer_pos, a.bearings_deg[0], a.levels_db[0], seed=3)
    r2 = f.run(a.times, a.observer_pos, a.bearings_deg[0], a.levels_db[0], seed=3)
    r3 = f.run(a.times, a.observer_pos, a.bearings_deg[0], a.levels_db[0], seed=4)
    assert r1.est.tobytes() == r2.est.tobytes()
    assert not np.array_equal(r1.est, r3.est)
    # measured bearings scatter around the truth with the paper's 1.5°
    d = a.truth[:, :2] - a.observer_pos
    true = np.degrees(np.arctan2(d[:, 0], d[:, 1]))
    err = (a.bearings_deg - true + 180) % 360 - 180
    assert 0.8 < err.std() < 2.2


def test_truth_driven_by_process_noise(table):
    """``truth_sigma_a``: one seeded track per run from the start state, velocity a random walk
    of variance σ_a²·t per axis; measurements follow each run's own track."""
    sc = get_scenario("static")
    sa = 1.5e-3
    d = sc.simulate(400, 2, table, truth_sigma_a=sa)
    assert d.truth.shape == (400, sc.times.size, 4)
    assert d.truth.tobytes() == sc.simulate(400, 2, table, truth_sigma_a=sa).truth.tobytes()
    np.testing.assert_allclose(d.truth[:, 0], np.broadcast_to(sc.target_x0(), (400, 4)))
    dv = d.truth[:, -1, 2:] - d.truth[:, 0, 2:]
    var = sa**2 * (sc.times[-1] - sc.times[0]) * 60.0  # Σ (σ_a·Δt)² over the steps
    assert 0.8 < dv.var(axis=0).mean() / var < 1.2
    rel = d.truth[:, :, :2] - d.observer_pos
    true = np.degrees(np.arctan2(rel[..., 0], rel[..., 1]))
    err = (d.bearings_deg - true + 180) % 360 - 180
    assert 1.3 < err.std() < 1.7
    assert sc.simulate(2, 2, table).truth.shape == (sc.times.size, 4)  # default unchanged


def _rmse(sc, est):
    return np.sqrt(np.mean(sc.position_error(est) ** 2, axis=0))


def test_manoeuvring_reduced_monte_carlo(table):
    """Reduced version of SPL paper fig. 3: errors of kilometres before the turn, a sharp drop
    during it (13-17 min), hundreds of metres after, never (much) below the BOT CRLB."""
    sc = get_scenario("manoeuvring")
    d = sc.simulate(12, 1, table)
    crlb = position_rmse_bound(sc.crlb())
    tmin = d.times / 60.0
    for use in (False, True):
        f = RegularizedParticleFilter(RPFConfig(n_particles=2000, use_levels=use, tl_table=table))
        res = f.run_many(d.times, d.observer_pos, d.bearings_deg, d.levels_db if use else None,
                         seed=11)
        rm = _rmse(sc, res.est)
        assert rm[tmin <= 13].min() > 2000
        assert rm[(tmin >= 20) & (tmin <= 26)].mean() < 400
        if not use:
            ok = tmin >= 18
            assert np.all(rm[ok] > 0.7 * crlb[ok])


@pytest.mark.slow
def test_paper_findings_200_runs(table):
    """SPL paper section 5 with 200 runs: SPL beats BOT after the manoeuvre; static observer
    table 1 shape (SPL an order of magnitude better at 36 and 63 min)."""
    sc = get_scenario("manoeuvring")
    d = sc.simulate(200, 3, table)
    rm = {}
    for use in (False, True):
        f = RegularizedParticleFilter(RPFConfig(use_levels=use, tl_table=table))
        rm[use] = _rmse(sc, f.run_many(d.times, d.observer_pos, d.bearings_deg,
                                       d.levels_db if use else None, seed=5).est)
    assert rm[True][-1] < rm[False][-1]
    assert 0.6 * 146.17 < rm[True][-1] < 1.4 * 146.17
    sc = get_scenario("static")
    d = sc.simulate(200, 3, table)
    for use in (False, True):
        f = RegularizedParticleFilter(RPFConfig(use_levels=use, tl_table=table))
        rm[use] = _rmse(sc, f.run_many(d.times, d.observer_pos, d.bearings_deg,
                                       d.levels_db if use else None, seed=5).est)
    for t in (36, 63):
        assert rm[True][t] < 0.2 * rm[False][t]


def test_rpf_through_the_tracker_registry():
    """``filter = "rpf"`` in ``arrayproc track``: the step interface via track_bearings."""
    from arrayproc.track.filters import FILTERS
    from arrayproc.track.runner import track_bearings

    assert "rpf" in FILTERS
    sc = get_scenario("manoeuvring")
    d = sc.simulate(1, 2)
    own = np.hstack([d.observer_pos, sc.observer.state(d.times)[1]])
    zs = np.deg2rad(d.bearings_deg[0])[:, None]
    zs = (zs + np.pi) % (2 * np.pi) - np.pi
    cfg = {"filter": "rpf", "model": "cv", "q1": (1.5e-3) ** 2 * 60.0, "q2": 0.0,
           "sigma_bearing_deg": 1.5, "params": {"n_particles": 2000, "seed": 1},
           "range_m": 10e3, "sigma_range_m": 2e3, "speed_mps": 1.54, "sigma_speed_mps": 1.03,
           "sigma_course_deg": 51.96}
    xs, ps, ws, status = track_bearings(d.times, zs, own, cfg)
    assert status == 0
    err = np.hypot(*(xs[-1, :2] + own[-1, :2] - d.truth[-1, :2]))
    assert err < 600.0
    assert np.all(np.linalg.eigvalsh(ps[-1]) > 0)
    with pytest.raises(ConfigError):
        track_bearings(d.times, zs, own, dict(cfg, model="ct"))


def test_rpf_step_interface_uses_levels():
    """The step RPF with the level + bearing measurement model (SPL paper eqs. (31)-(33)) on
    the static scenario: errors at 63 min far below the same filter on bearings alone (table
    1's 203 m vs 4338 m)."""
    from arrayproc.track.filters.particle import RPF
    from arrayproc.track.init import TrackPrior, init_from_bearing
    from arrayproc.track.models.bearing import Bearing
    from arrayproc.track.models.level_bearing import LevelBearing
    from arrayproc.track.models.motion import constant_turn, constant_velocity
    from arrayproc.track.state import Context

    sc = get_scenario("static")
    d = sc.simulate(4, 8)
    own = np.hstack([d.observer_pos, sc.observer.state(d.times)[1]])
    prior = TrackPrior(sigma_bearing_deg=1.5, range_m=10e3, sigma_range_m=2e3, speed_mps=1.54,
                       sigma_speed_mps=1.03, sigma_course_deg=51.96)
    cv = constant_velocity()
    models = {False: Bearing(sigma_deg=1.5),
              True: LevelBearing(sigma_deg=1.5, tl_table="munk_bellhopcxx_incoherent")}
    err = {}
    for use in (False, True):
        e = []
        for r in range(4):
            f = RPF(n_particles=2000, sigma_a=1.5e-3, seed=r)
            s = f.initialize(*init_from_bearing(d.bearings_deg[r, 0], own[0], prior, 4))
            for k in range(1, 64):
                ctx = Context(own[k], own[k - 1])
                s = f.predict(s, cv, 60.0, ctx)
                th = np.deg2rad(d.bearings_deg[r, k])
                z = [th, d.levels_db[r, k]] if use else [th]
                s, lp = f.update(s, z, models[use], ctx)
                assert np.isfinite(lp)
            e.append(np.hypot(*(s.x[:2] + own[63, :2] - d.truth[63, :2])))
        err[use] = np.sqrt(np.mean(np.square(e)))
    assert err[True] < 0.3 * err[False]
    with pytest.raises(ArrayprocError, match="no_such_table"):
        LevelBearing(tl_table="no_such_table")
    with pytest.raises(ConfigError):
        f.predict(s, constant_turn(), 60.0, ctx)
