"""arrayproc track: products bearings + recording nav → tracks group."""

from __future__ import annotations

import math
import os

import h5py
import numpy as np
import pytest

from arrayproc.data import data_path
from arrayproc.errors import ArrayprocError
from arrayproc.evaluate.montecarlo import LRScenario
from arrayproc.geo.angles import wrap_pi
from arrayproc.io.products import ProductsWriter, read_products
from arrayproc.track.runner import assign_by_continuity, load_tracker_config, run_tracker
from tests._tolerance import assert_close_to_scale

DATA = str(data_path("trackers"))


def _write_inputs(tmp_path, seed=3, extra_rows=True):
    """A recording with the section-V ownship nav (1 s fixes) and a products file with the
    bearing pairs of Case I (plus weaker clutter rows that must be ignored)."""
    scn = LRScenario(case=1)
    obs = scn.observer()
    nt = np.arange(0.0, 1801.0, 1.0)
    p, _, c = obs.state(nt)
    rec = tmp_path / "rec.h5"
    with h5py.File(rec, "w") as f:
        f["time_data"] = np.zeros((16, 1))
        f["time_data"].attrs["sample_freq"] = 1000.0
        f["nav/time"] = nt
        f["nav/position"] = p
        f["nav/heading"] = c
        tgt = scn.target()
        f["truth/sources/target/position"] = tgt.state(nt)[0]
    g = scn.geometry()
    rng = np.random.default_rng(seed)
    theta = np.arctan2(g["rel"][:, 0], g["rel"][:, 1]) + rng.normal(0, math.radians(1.5),
                                                                      g["times"].size)
    d = np.rad2deg(np.angle(np.exp(1j * (theta - g["heading"]))))
    cone = np.abs(d)
    hd = np.rad2deg(g["heading"])
    port, stbd = np.mod(hd - cone, 360), np.mod(hd + cone, 360)
    t = g["times"]
    snr = np.full(t.size, 20.0)
    if extra_rows:
        t = np.concatenate([t, t[::3]])
        port = np.concatenate([port, np.full(t.size - port.size, 10.0)])
        stbd = np.concatenate([stbd, np.full(t.size - stbd.size, 200.0)])
        snr = np.concatenate([snr, np.full(t.size - snr.size, 3.0)])
        cone = np.concatenate([cone, np.full(t.size - cone.size, 30.0)])
    prod = tmp_path / "prod.h5"
    with ProductsWriter(prod, source=str(rec)) as w:
        gb = w.group("bearings", "bearings")
        gb.append(time=t, cone_deg=cone, bearing_port_deg=port, bearing_stbd_deg=stbd,
                  level_db=snr + 100, snr_db=snr, freq_lo=np.full(t.size, 200.0),
                  freq_hi=np.full(t.size, 900.0), spl_db=snr + 90)
    return rec, prod, g


@pytest.mark.parametrize("cfg", ["ukf_lr.toml", "srf_known_side.toml"])
def test_run_tracker_writes_tracks_near_truth(tmp_path, cfg):
    rec, prod, g = _write_inputs(tmp_path)
    out = tmp_path / "tracks.h5"
    run_tracker(str(prod), os.path.join(DATA, cfg), str(out))
    tr = read_products(str(out))["tracks"]
    assert tr["kind"] == "tracks"
    n = g["times"].size
    for k in ("time", "track_id", "x", "y", "vx", "vy"):
        assert tr[k].shape == (n,)
    assert tr["cov"].shape == (n, 4, 4)
    np.testing.assert_allclose(tr["cov"], np.swapaxes(tr["cov"], 1, 2), atol=1e-6)
    assert np.all(np.linalg.eigvalsh(tr["cov"]) > 0)
    # starboard is the true side only after the turn for this geometry; the L-R tracker and
    # the known-side tracker on the true column must both end within 1 km of the truth
    err = math.hypot(tr["x"][-1] - g["target"][-1, 0], tr["y"][-1] - g["target"][-1, 1])
    if cfg == "ukf_lr.toml":
        assert err < 1000.0
    # ownship columns are the nav interpolated at the bearing times
    np.testing.assert_allclose(tr["own_x"], g["own"][:, 0], atol=1e-6)


def test_run_tracker_plot(tmp_path):
    from arrayproc.plots.track import plot_track
    rec, prod, g = _write_inputs(tmp_path)
    out = tmp_path / "tracks.h5"
    run_tracker(str(prod), os.path.join(DATA, "ukf_lr.toml"), str(out))
    png = tmp_path / "track.png"
    plot_track(str(out), str(png))
    assert png.stat().st_size > 10_000


def test_user_errors_are_one_line(tmp_path):
    rec, prod, _ = _write_inputs(tmp_path)
    bad = tmp_path / "bad.toml"
    bad.write_text("[tracker]\nfilter = 'ukf'\nbogus = 1\n")
    with pytest.raises(ArrayprocError, match="tracker.bogus"):
        load_tracker_config(str(bad))
    bad.write_text("[tracker]\nfilter = 'nope'\n")
    with pytest.raises(ArrayprocError, match="tracker.filter"):
        run_tracker(str(prod), str(bad), str(tmp_path / "o.h5"))
    bad.write_text("[tracker]\nlr = false\n")
    with pytest.raises(ArrayprocError, match="side"):
        load_tracker_config(str(bad))
    with pytest.raises(ArrayprocError, match="no such file"):
        run_tracker(str(tmp_path / "missing.h5"), os.path.join(DATA, "ukf_lr.toml"),
                    str(tmp_path / "o.h5"))
    os.remove(rec)
    with pytest.raises(ArrayprocError, match="not found"):
        run_tracker(str(prod), os.path.join(DATA, "ukf_lr.toml"), str(tmp_path / "o.h5"))
    assert not (tmp_path / "o.h5").exists()
    assert not [p for p in os.listdir(tmp_path) if p.endswith(".part")]


def test_assign_by_continuity_follows_a_turn_through_the_target():
    # ownship turns 0° → 100° at 5°/step while the target stays on 50°: the array axis sweeps
    # through the target, port and starboard swap roles and the ghost 2h − θ crosses the truth
    h = np.deg2rad(np.arange(0.0, 101.0, 5.0))
    true = np.full(h.size, np.deg2rad(50.0))
    d = np.angle(np.exp(1j * (true - h)))
    port, stbd = h - np.abs(d), h + np.abs(d)
    z = assign_by_continuity(port, stbd)
    ghost = np.angle(np.exp(1j * (2 * h - true)))
    wrapped = np.angle(np.exp(1j * z))
    i_true = int(np.argmin(np.abs(wrapped[1] - true[1])))
    np.testing.assert_allclose(wrapped[:, i_true], true, atol=1e-12)
    np.testing.assert_allclose(wrapped[:, 1 - i_true], ghost, atol=1e-12)


@pytest.mark.parametrize("name", ["ekf", "ukf", "srf"])
def test_runner_components_equal_the_fused_kernel(name):
    """The runner's wiring (filter objects, bearing model, LRResolver) and the fused L-R
    Monte Carlo kernel compute the same numbers, to rounding."""
    from arrayproc.track.filters import make_filter
    from arrayproc.track.init import TrackPrior
    from arrayproc.track.manage import _kernels as kl
    from arrayproc.track.manage.lr import fused_kind
    from arrayproc.track.runner import track_bearings

    scn = LRScenario(case=1)
    g = scn.geometry()
    y1, y2, _, _ = scn.measurements(1, 4)
    zs = np.stack([y1[0], y2[0]], axis=1)
    cfg = load_tracker_config(os.path.join(DATA, "ukf_lr.toml"))
    cfg["filter"] = name
    cfg["params"] = {}
    xs, Ps, ws, st = track_bearings(g["times"], zs, g["own"], cfg)
    filt = make_filter(name)
    K = g["times"].size
    kx, kP, kw = np.empty((K, 4)), np.empty((K, 4, 4)), np.empty((K, 2))
    p = TrackPrior(sigma_bearing_deg=cfg["sigma_bearing_deg"], range_m=cfg["range_m"],
                   sigma_range_m=cfg["sigma_range_m"], speed_mps=cfg["speed_mps"],
                   sigma_speed_mps=cfg["sigma_speed_mps"]).as_array()
    kst = kl.run_track(fused_kind(filt), 2, g["times"], zs, g["own"],
                       math.radians(cfg["sigma_bearing_deg"]), cfg["q1"], cfg["q2"], p,
                       np.array([p[0], p[2], 0.0]), *filt.kernel_points(4), kx, kP, kw)
    assert st == kst
    # two compiled paths of one recursion: rounding only, 1e-10 of scale (RECURSION_REL)
    assert_close_to_scale(xs, kx, err_msg="state")
    assert_close_to_scale(Ps, kP, err_msg="covariance")
    assert_close_to_scale(ws, kw, err_msg="weights")


def test_cone_gate_selects_rows_and_is_validated(tmp_path):
    """tracker.cone_gate keeps the rows inside [lo, hi] (e.g. out of the tow ship's sector)."""
    from arrayproc.errors import ConfigError as _ConfigError
    from arrayproc.track.runner import _read_bearings, load_tracker_config
    t = np.repeat(np.arange(5.0), 2)
    cone = np.tile([15.0, 120.0], 5)
    snr = np.tile([20.0, 8.0], 5)  # the tow ship is the louder
    prod = {"/": {}, "b": {"kind": "bearings", "time": t, "cone_deg": cone,
                           "bearing_port_deg": 360 - cone, "bearing_stbd_deg": cone,
                           "snr_db": snr}}
    assert np.all(_read_bearings(prod, None, "p.h5")["bearing_stbd_deg"] == 15.0)
    gated = _read_bearings(prod, None, "p.h5", [60.0, 180.0])
    assert np.all(gated["bearing_stbd_deg"] == 120.0) and gated["time"].size == 5
    bad = tmp_path / "t.toml"
    bad.write_text('[tracker]\ncone_gate = [100.0, 20.0]\n')
    with pytest.raises(_ConfigError, match="cone_gate"):
        load_tracker_config(str(bad))


def test_levels_reach_the_particle_filter(tmp_path):
    """tracker.level feeds a bearings column of received levels to the RPF (SPL paper eqs.
    (31)-(33)): on the static scenario the error at 63 min falls well below bearings-only."""
    from arrayproc.evaluate.scenarios import get_scenario
    from arrayproc.track.runner import track_bearings

    sc = get_scenario("static")
    d = sc.simulate(3, 5)
    own = np.hstack([d.observer_pos, sc.observer.state(d.times)[1]])
    cfg = {"filter": "rpf", "model": "cv", "q1": (1.5e-3) ** 2 * 60.0, "q2": 0.0,
           "sigma_bearing_deg": 1.5, "range_m": 10e3, "sigma_range_m": 2e3, "speed_mps": 1.54,
           "sigma_speed_mps": 1.03, "sigma_course_deg": 51.96,
           "params": {"n_particles": 2000, "sigma_a": 1.5e-3,
                      "tl_table": "munk_bellhopcxx_incoherent"}}
    k = 64
    err = {}
    for use in (False, True):
        e = []
        for r in range(3):
            zs = wrap_pi(np.deg2rad(d.bearings_deg[r, :k]))[:, None]
            c = dict(cfg, params=dict(cfg["params"], seed=r))
            xs, _, _, status = track_bearings(d.times[:k], zs, own[:k], c,
                                              d.levels_db[r, :k] if use else None)
            assert status == 0
            e.append(np.hypot(*(xs[-1, :2] + own[k - 1, :2] - d.truth[k - 1, :2])))
        err[use] = np.sqrt(np.mean(np.square(e)))
    assert err[True] < 0.3 * err[False]
    bad = tmp_path / "t.toml"
    bad.write_text('[tracker]\nfilter = "srf"\nlevel = "spl_db"\n')
    with pytest.raises(ArrayprocError, match="tracker.level needs a filter"):
        load_tracker_config(str(bad))


def test_levels_reach_a_gaussian_filter():
    """The level + bearing model is a measurement model like any other: a UKF takes it too
    (SPL paper eqs. (31)-(33) in a sample-point update) and, on the static scenario, its error
    at 63 min is well below the same UKF on bearings alone."""
    from arrayproc.evaluate.scenarios import get_scenario
    from arrayproc.track.runner import track_bearings

    sc = get_scenario("static")
    d = sc.simulate(3, 5)
    own = np.hstack([d.observer_pos, sc.observer.state(d.times)[1]])
    cfg = {"filter": "ukf", "model": "cv", "q1": (1.5e-3) ** 2 * 60.0, "q2": 0.0,
           "sigma_bearing_deg": 1.5, "range_m": 10e3, "sigma_range_m": 2e3, "speed_mps": 1.54,
           "sigma_speed_mps": 1.03, "sigma_course_deg": 51.96,
           "params": {"tl_table": "munk_bellhopcxx_incoherent", "sigma_level_db": 4.0}}
    k = 64
    err = {}
    for use in (False, True):
        e = []
        for r in range(3):
            zs = wrap_pi(np.deg2rad(d.bearings_deg[r, :k]))[:, None]
            xs, _, _, status = track_bearings(d.times[:k], zs, own[:k], cfg,
                                              d.levels_db[r, :k] if use else None)
            assert status & 4 == 0
            e.append(np.hypot(*(xs[-1, :2] + own[k - 1, :2] - d.truth[k - 1, :2])))
        err[use] = np.sqrt(np.mean(np.square(e)))
    assert err[True] < 0.5 * err[False]
