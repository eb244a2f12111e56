"""The paper scenario modules of arrayproc.evaluate: their helpers against closed forms and
against the components they compose."""

from __future__ import annotations

import numpy as np
import pytest

from arrayproc.evaluate.association import associate
from arrayproc.evaluate.scenarios import active_tracking as at
from arrayproc.evaluate.scenarios import compact_paper as cp
from arrayproc.evaluate.scenarios import spl_paper as spl
from arrayproc.evaluate.scenarios import thesis_active as ta
from arrayproc.evaluate.scenarios import thesis_passive as tp
from arrayproc.evaluate.scenarios import thesis_tma as tt


# -- SPL paper -------------------------------------------------------------------------------
def test_compare_with_paper_reads_our_curves_at_the_paper_times():
    tmin = np.arange(0.0, 31.0)
    rm = {"bot": 1000.0 - 10 * tmin, "spl": 500.0 - 5 * tmin}
    rm["bot"][20] = 50.0  # a minimum after the turn at 20 min, one before it at 10 min
    rm["bot"][10] = 10.0
    rows, extra = spl.compare_with_paper("manoeuvring", tmin, rm, np.full(31, 100.0))
    assert [r["time_min"] for r in rows] == [24.0, 30.0]
    assert rows[1]["ours_bot_m"] == rm["bot"][30] and rows[1]["paper_spl_m"] == 146.17
    assert extra["min_rmse_bot_m"] == 50.0 and extra["min_rmse_bot_time_min"] == 20.0
    rows, extra = spl.compare_with_paper("parallel", tmin, rm, np.full(31, 400.0))
    assert extra["spl_below_crlb_from_min"] == 21.0  # 500 − 5 t < 400 from t = 21
    assert extra["final_ratio_bot_over_spl"] == pytest.approx(rm["bot"][-1] / rm["spl"][-1])
    rows, extra = spl.compare_with_paper("static", tmin, rm, np.full(31, 7.0))
    assert extra["min_rmse_bot_time_min"] == 10.0 and rows[-1]["ours_bot_m"] == 7.0


def test_rpf_monte_carlo_is_the_filter_on_per_run_seeds():
    """The harness gives what the filter gives on run_seeds(seed, R, tag) directly."""
    from arrayproc.acoustics.tl import load_default_table
    from arrayproc.track.filters.particle import RegularizedParticleFilter, RPFConfig, run_seeds
    sc = spl.get_scenario("manoeuvring")
    tab = load_default_table()
    data = sc.simulate(2, 4, tab)
    got = spl.rpf_monte_carlo(sc, data, tab, particles=200, seed=4)
    cfg = RPFConfig(n_particles=200, use_levels=True, tl_table=tab,
                    sigma_bearing_deg=sc.sigma_bearing_deg,
                    sigma_level_db=sc.sigma_level_filter_db)
    res = RegularizedParticleFilter(cfg).run_many(data.times, data.observer_pos,
                                                  data.bearings_deg, data.levels_db,
                                                  seeds=run_seeds(4, 2, tag=2))
    err = np.linalg.norm(res.est[..., :2] - data.truth[..., :2], axis=-1)
    assert np.array_equal(got["rmse_spl"], np.sqrt(np.mean(err ** 2, axis=0)))
    assert got["rmse_bot"].shape == got["rmse_spl"].shape == (data.times.size,)
    assert 0 <= got["resampling_fraction_bot"] <= 1


# -- compact-array paper ---------------------------------------------------------------------
def test_ou_noise_has_the_paper_covariance():
    """σ² variance and lag-1 correlation exp(−Δt/τ) (tolerances: 4 σ of the estimates from
    20000 samples)."""
    t = np.arange(20000) * cp.DT
    e = cp.ou_noise(np.random.default_rng(1), t, cp.CORR)
    rho = np.exp(-cp.DT / cp.CORR)
    n_eff = t.size * (1 - rho) / (1 + rho)
    assert e.var() == pytest.approx(cp.SIGMA ** 2, rel=4 * np.sqrt(2 / n_eff))
    assert np.corrcoef(e[:-1], e[1:])[0, 1] == pytest.approx(rho, abs=4 * (1 - rho ** 2)
                                                              / np.sqrt(t.size))
    w = cp.ou_noise(np.random.default_rng(1), t[:5000], 0.0)
    assert abs(np.corrcoef(w[:-1], w[1:])[0, 1]) < 4 / np.sqrt(5000)


def test_truth_passes_the_cpa_at_mid_window():
    for d in cp.CPAS:
        q = cp.truth(d)
        g = q[2]
        p = q[:2] + cp.SPEED * cp.DURATION / 2 * np.array([np.sin(g), np.cos(g)])
        assert np.hypot(*p) == pytest.approx(d, rel=1e-12)
        assert p @ np.array([np.sin(g), np.cos(g)]) == pytest.approx(0.0, abs=1e-9 * d)


# -- thesis 3.3.3 ----------------------------------------------------------------------------
def test_c6_sigma_theta_is_the_delay_information_of_the_line():
    """Eq. (C.6): J = Σ_n (n δx sin θ / (σ_τ c))², n = 0..N_H − 1, summed directly."""
    n = np.arange(tt.N_H)
    j = np.sum((n * tt.DX * np.sin(np.deg2rad(70.0)) / (tt.SIGMA_TAU * tt.C)) ** 2)
    assert tt.c6_sigma_theta(70.0) == pytest.approx(np.rad2deg(1 / np.sqrt(j)), rel=1e-12)


# -- thesis chapter 2 ------------------------------------------------------------------------
def test_passive_closed_forms_hold():
    assert tp.pattern_error(90.0) < 1e-3            # dB; measured 2.3e-5 dB
    assert tp.beamwidth_ratio(90.0) == pytest.approx(1.0, abs=0.01)


def test_dense_response_of_a_delta_is_flat():
    f, mag = tp.dense_response(np.array([0.0, 1.0, 0.0]), 1000.0, n=64)
    assert f.size == 64 and np.allclose(mag, 1.0)


# -- thesis chapter 4 / active tracking ------------------------------------------------------
def test_expected_echo_snr():
    """EL − NL + 10 log T + 10 log N − 1.76: 100 − 55 + 6.02 + 15.05 − 1.76 dB."""
    got = ta.expected_echo_snr_db(100.0, 55.0, 4.0, 32)
    assert got == pytest.approx(45.0 + 10 * np.log10(4.0) + 10 * np.log10(32) - 1.76,
                                rel=1e-15)


def test_submarine_summary():
    rows = [{"snr_expected_db": 20.0, "detected": True, "range_err_cells": -2.0,
             "range_rate_err": 0.1, "moving": True},
            {"snr_expected_db": 20.0, "detected": False},
            {"snr_expected_db": 5.0, "detected": False}]
    s = ta.submarine_summary(rows)
    assert s["detection_rate"] == 0.5 and s["max_abs_range_err_cells"] == 2.0
    assert s["moving_fraction"] == 1.0
    assert ta.submarine_summary([])["detection_rate"] == 0.0


def test_associate_picks_the_nearest_echo_of_the_same_ping_inside_the_gates():
    truth = {"ping": np.array([0, 0, 1]), "range_array_m": np.array([1000.0, 1020.0, 1000.0]),
             "cone_deg": np.array([40.0, 40.0, 40.0])}
    contacts = {"ping": np.array([0, 0, 1, 1]), "range_m": np.array([1014.0, 1500.0, 1004.0,
                                                                      1004.0]),
                "cone_deg": np.array([41.0, 40.0, 40.0, 50.0])}
    assert associate(contacts, truth, 30.0, 3.0).tolist() == [1, -1, 2, -1]


def test_mirror_across_the_array_axis():
    own = np.array([[100.0, 200.0]])
    p = np.array([[100.0 + 30.0, 200.0 + 40.0]])      # 30 m east, 40 m north of the array
    m = at._mirror(own, np.array([0.0]), p)          # heading north: x flips
    assert np.allclose(m, [[70.0, 240.0]])
    assert np.allclose(at._mirror(own, np.array([0.0]), m), p)
    on_axis = np.array([[100.0, 500.0]])
    assert np.allclose(at._mirror(own, np.array([0.0]), on_axis), on_axis)


def test_stats():
    s = at.stats(np.array([3.0, -4.0]))
    assert s == {"n": 2, "mean": -0.5, "median": -0.5, "rms": round(np.sqrt(12.5), 3),
                 "max_abs": 4.0}
    assert at.stats(np.array([])) == {"n": 0}


# -- L-R paper -------------------------------------------------------------------------------
def test_example_run_matches_the_fused_monte_carlo_kernel():
    """The filter objects + LRResolver (fig. 4's run) and the fused kernel of the Monte Carlo
    give the same known-side track from the same draws (different code: relative 1e-6 of
    the range, rounding of the two implementations)."""
    from arrayproc.evaluate.montecarlo import run_case
    from arrayproc.evaluate.scenarios import lr_paper
    scn = lr_paper.LRScenario(case=1)
    ex = lr_paper.example_run(scn, "ekf", {}, 7)
    mc = run_case(scn, "ekf", False, 1, 7)
    got = ex["known"] - ex["own"]
    want = mc.est[0, :, :2]
    scale = np.linalg.norm(want, axis=1).max()
    assert np.max(np.abs(got - want)) < 1e-6 * scale


def test_table_case_rows_carry_the_paper_numbers():
    from arrayproc.evaluate.scenarios import lr_paper
    rows, curves, t_ref = lr_paper.table_case(lr_paper.LRScenario(case=2), ["ekf"], 4, 3, {})
    r = rows["ekf"]
    assert r["paper_track_loss_pct_resolved"] == 12.35 and 0 <= r["true_side_pct"] <= 100
    assert r["relative_time_known_side"] == 1.0 and t_ref == r["seconds_known_side"]
    assert curves["rmse"]["ekf"][0].shape == (31,)


# -- thesis 3.2.1.2 --------------------------------------------------------------------------
def test_narrowband_truth_of_a_stationary_source():
    """Receiver moving at U past a fixed source: abeam (90°) at mid-run, and the received
    frequency f0 (1 + U cos θ / c), so the EKF state frequency is f0 (central difference of
    the emission time: relative 1e-9)."""
    from arrayproc.evaluate.scenarios import thesis_narrowband as nb
    speed, dur = 2.5, 200.0
    geo = nb.geometry("stationary", speed, dur)
    x = -np.arange(nb.N_H) * nb.SPACING
    t = np.array([0.0, dur / 2 - x.mean() / speed, dur])   # the array centre abeam at mid-run
    cone, f_rec, f_state = nb.truth(t, geo, x, speed)
    assert cone[1] == pytest.approx(90.0, abs=1e-6)
    assert cone[0] < 90.0 < cone[2]
    assert np.allclose(f_state, nb.F0, rtol=1e-9)
    assert f_rec[0] > nb.F0 > f_rec[2]


# -- thesis fig. 4.4 -------------------------------------------------------------------------
def test_doppler_spread_costs_the_bpsk_more_than_the_hfm():
    """Distortion lowers the matched-filter peak, the Doppler-sensitive BPSK's more than the
    HFM's (thesis fig. 4.4; measured at 0.5 ms: 9.5 dB and 4.4 dB)."""
    from arrayproc.evaluate.scenarios import thesis_doppler_spread as ds
    loss = {}
    for kind, w in ds.pulses().items():
        p0 = ds.peak(ds.direct(w, 0.0), w, kind)
        p1 = ds.peak(ds.direct(w, 0.5e-3), w, kind)
        loss[kind] = 20 * np.log10(p0 / p1)
    assert 0.0 < loss["hfm"] < loss["bpsk"]


def test_active_scene_reads_the_truth_groups(tmp_path):
    """io.truth.active_scene through ActiveTruth: the interpolated ownship and submarine."""
    import h5py
    p = tmp_path / "t.h5"
    with h5py.File(p, "w") as f:
        f.attrs["sound_speed"] = 1490.0
        f["truth/pings/time"] = np.array([0.0, 30.0])
        for g, extra in (("truth/sources/submarine", {}),
                         ("truth/ownship", {"heading": np.array([350.0, 10.0])})):
            f[f"{g}/time"] = np.array([0.0, 60.0])
            f[f"{g}/position"] = np.array([[0.0, 0.0], [60.0, 120.0]])
            f[f"{g}/velocity"] = np.array([[1.0, 2.0], [1.0, 2.0]])
            for k, v in extra.items():
                f[f"{g}/{k}"] = v
        f["truth/scatterers/name"] = np.array([b"submarine", b"rock"])
        f["truth/scatterers/kind"] = np.array([b"target", b"clutter"])
        f["truth/scatterers/position0"] = np.array([[0.0, 0.0, 50.0], [10.0, 20.0, 90.0]])
        for k in ("ping", "target", "time", "range_m", "range_rate_mps"):
            f[f"truth/echoes/{k}"] = np.array([0, 1])
    tr = at.read_truth(p)
    assert tr.c == 1490.0 and tr.i_sub == 0 and tr.clutter.tolist() == [False, True]
    assert np.allclose(tr.sc_pos, [[0.0, 0.0], [10.0, 20.0]])
    xy, v, hd = tr.own_at(np.array([30.0]))
    assert np.allclose(xy, [[30.0, 60.0]]) and np.allclose(v, [[1.0, 2.0]])
    assert hd[0] == pytest.approx(0.0, abs=1e-9) or hd[0] == pytest.approx(360.0)  # unwrapped
    assert np.allclose(tr.sub_at(np.array([15.0]))[0], [[15.0, 30.0]])
