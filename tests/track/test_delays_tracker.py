"""Recursive TDOA position tracker (``measurements = "delays"``, thesis 3.2.2.2, eqs.
(3.37)-(3.40)): convergence on noiseless delays, covariance consistency (NEES) in a seeded
Monte Carlo, the CV option, and the ``arrayproc track`` path through products and /nav."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import chi2

from arrayproc.errors import ConfigError, FormatError
from arrayproc.geo.tdoa import predicted_delays, reference_covariance
from arrayproc.io.products import ProductsWriter, read_products
from arrayproc.io.recording import RecordingWriter
from arrayproc.track.batch import scenarios as S
from arrayproc.track.delays import (
    StaticPosition,
    initial_hypotheses,
    load_delays_config,
    track_delays,
)
from arrayproc.track.runner import load_tracker_config, run_tracker
from arrayproc.track.state import Context

N_H, DX = 21, 1.0          # the thesis's 20 m array
C = 1500.0
SOURCE = np.array([2500.0, 1500.0])   # static, starboard of both legs


def _geometry(dt=10.0):
    """Ownship 3 m/s, 0° then 315° (S.turn_track); the array's elements (B, N, 3) trailing
    the ownship (element 0 the reference), 50 m deep."""
    tr = S.turn_track(dt=dt)
    el2 = S.line_elements(tr, N_H, DX)
    el = np.concatenate([el2, np.full(el2.shape[:2] + (1,), 50.0)], axis=-1)
    return tr, el


def _delays(el, source_xy, src_depth=50.0):
    s = np.broadcast_to(np.r_[source_xy, src_depth], (el.shape[0], 3)) if np.ndim(
        source_xy) == 1 else np.c_[source_xy, np.full(len(source_xy), src_depth)]
    return np.stack([predicted_delays(s[b], el[b], 0, C) for b in range(el.shape[0])])


def _velocity(tr, speed=3.0):
    """The ownship's (and array's) velocity along its heading, (B, 2) m/s."""
    return speed * np.stack([np.sin(tr.heading), np.cos(tr.heading)], -1)


def _moving(tau, el, source_xy, vel):
    """Delays a moving array measures, τ / (1 + V·u/c) (batch/motion.py eq. (M1)), u the
    unit vector from the reference element to the source."""
    d = np.broadcast_to(source_xy, el[:, 0, :2].shape) - el[:, 0, :2]
    u = d / np.hypot(d[:, 0], d[:, 1])[:, None]
    return tau / (1.0 + np.einsum("bi,bi->b", vel, u) / C)[:, None]


def test_static_model_is_eq_3_40_in_relative_coordinates():
    m = StaticPosition(q=2.0)
    ctx = Context(np.array([10.0, 20.0, 1.0, 0.0]), np.array([4.0, 5.0, 1.0, 0.0]))
    x = np.array([100.0, 200.0])
    # absolute position constant: x_rel + o_prev = x_rel' + o
    assert np.allclose(m.function(x, 3.0, ctx) + ctx.own[:2], x + ctx.own_prev[:2])
    assert np.allclose(m.covariance(3.0), 6.0 * np.eye(2))
    assert np.allclose(m.jacobian(x, 3.0, ctx), np.eye(2))


def test_initial_hypotheses_are_the_mirror_bearings_of_the_plane_wave():
    tr, el = _geometry()
    tau = _delays(el[:1], SOURCE)[0]
    d = {"motion": "static", "range_m": 4000.0, "sigma_range_m": 2000.0,
         "sigma_bearing_deg": 0.5, "side": "auto", "sigma_speed_mps": 3.0}
    states, sides = initial_hypotheses(tau, np.full(N_H, 1e-6), el[0] - el[0, 0], 0, C,
                                       float(tr.heading[0]), np.zeros(2), d)
    assert sides == ["port", "starboard"]
    # the least-squares plane wave through near-field delays τ_n ≈ (n Δ cos θ + n² Δ² sin² θ
    # / 2r) / c (n hydrophones behind the reference) has the bearing seen from the point
    # Σn³ / (2 Σn²) Δ behind the reference
    n = np.arange(N_H)
    back = (n**3).sum() / (2 * (n**2).sum()) * DX
    p = el[0, 0, :2] + back * (el[0, -1, :2] - el[0, 0, :2]) / ((N_H - 1) * DX)
    true_brg = math.atan2(*(SOURCE - p))
    stbd = states[1].x
    assert math.atan2(stbd[0], stbd[1]) == pytest.approx(true_brg, abs=3e-5)
    assert np.hypot(*stbd) == pytest.approx(4000.0)
    port = states[0].x                        # mirrored about the array's axis (north)
    assert port[0] == pytest.approx(-stbd[0]) and port[1] == pytest.approx(stbd[1])
    # the covariance: σ_r along the bearing, r σ_θ across it
    u = stbd / np.hypot(*stbd)
    assert u @ states[1].P @ u == pytest.approx(2000.0**2)
    v = np.array([u[1], -u[0]])
    assert v @ states[1].P @ v == pytest.approx((4000.0 * math.radians(0.5)) ** 2)


@pytest.mark.parametrize("filt", ["ekf", "ukf", "ckf", "ghf"])
def test_static_noiseless_delays_converge_to_truth(filt):
    tr, el = _geometry()
    tau = _delays(el, SOURCE)
    d = {"motion": "static", "range_m": 4000.0, "sigma_range_m": 2500.0, "side": "auto",
         "sigma_delay_s": 1e-6}
    r = track_delays(tr.time, tau, None, el, 0, C, d, filt, heading_rad=tr.heading)
    err = np.hypot(r["x"] - SOURCE[0], r["y"] - SOURCE[1])
    sig = np.sqrt(np.trace(r["P"], axis1=1, axis2=2))
    assert err[-1] < 1.0                       # 2.9 km away, noiseless delays
    assert err[-1] < 3 * sig[-1] + 0.05
    assert r["side_weight"][-1] > 0.999        # the turn tells the mirrors apart
    assert np.all(r["updated"]) and np.all(r["n_delays"] == N_H - 1)
    assert np.allclose(r["vx"], 0) and np.allclose(r["cov"][:, 2:, 2:], 0)
    # the relative state is the absolute position minus the reference hydrophone's
    assert np.allclose(r["rel"] + el[:, 0, :2], np.c_[r["x"], r["y"]])


def test_static_nees_is_consistent_in_a_seeded_monte_carlo():
    """Delays with noise of the model's covariance (independent arrival-time errors, σ/√2 per
    channel, so every delay has σ and shares the reference's half); the mean NEES at the end
    and at the end of the first leg lies in the two-sided 99 % interval of χ²(2R)/R."""
    tr, el = _geometry()
    tau0 = _delays(el, SOURCE)
    sig = 2e-5
    runs = 60
    rng = np.random.default_rng(190)
    d = {"motion": "static", "range_m": 3000.0, "sigma_range_m": 1500.0, "side": "starboard",
         "sigma_delay_s": sig}
    nees = np.empty((runs, tr.time.size))
    for k in range(runs):
        e = rng.normal(0.0, sig / math.sqrt(2), tau0.shape)
        tau = tau0 + e - e[:, :1]
        r = track_delays(tr.time, tau, None, el, 0, C, d, "ukf", heading_rad=tr.heading)
        dx = np.c_[r["x"] - SOURCE[0], r["y"] - SOURCE[1]]
        nees[k] = np.einsum("bi,bij,bj->b", dx, np.linalg.inv(r["P"]), dx)
    lo, hi = chi2.ppf([0.005, 0.995], 2 * runs) / runs
    mid = tr.time.size // 2 - 1
    for b in (mid, -1):
        assert lo < nees[:, b].mean() < hi, (b, nees[:, b].mean(), lo, hi)
    # and the model's noise covariance is what the draw above has
    R = reference_covariance(np.full(N_H - 1, sig))
    dd = (tau - tau0)[:, 1:]
    assert np.allclose(np.cov(dd.T), R, atol=0.5 * sig**2)


def test_range_bank_keeps_the_ekf_on_a_near_source():
    """One wide prior (6 ± 4 km) for a source 1.2 km away: the EKF's first update, linearised
    at 6 km, leaves the source km away; the range-parameterised bank (priors from 1 to 20 km)
    converges, and its initial members are the geometric ranges with σ_r = r (ρ − 1)/2."""
    tr, el = _geometry()
    near = el[0, 0, :2] + 1200.0 * np.array([math.sin(1.2), math.cos(1.2)])
    tau = _delays(el, near)
    d = {"motion": "static", "range_m": 6000.0, "sigma_range_m": 4000.0,
         "sigma_delay_s": 2e-6}
    one = track_delays(tr.time, tau, None, el, 0, C, d, "ekf", heading_rad=tr.heading)
    bank = {**d, "range_bank": [1000.0, 20000.0, 6]}
    r = track_delays(tr.time, tau, None, el, 0, C, bank, "ekf", heading_rad=tr.heading)
    e_one = np.hypot(one["x"][-1] - near[0], one["y"][-1] - near[1])
    e_bank = np.hypot(r["x"] - near[0], r["y"] - near[1])
    assert e_bank[-1] < 0.5 and e_one > 100.0
    assert r["n_hypotheses"] == 12 and list(r["side"]) == ["port", "starboard"]
    assert r["side_weight"][-1] > 0.999
    states, sides = initial_hypotheses(tau[0], np.full(N_H, 2e-6), el[0] - el[0, 0], 0, C,
                                       float(tr.heading[0]), np.zeros(2),
                                       {**bank, "sigma_bearing_deg": 0.5, "side": "auto"})
    rho = 20.0 ** (1 / 5)
    rng = np.array([np.hypot(*st.x) for st in states])
    assert np.allclose(rng, np.tile(1000.0 * rho ** np.arange(6), 2))
    assert sides == ["port"] * 6 + ["starboard"] * 6
    u = states[9].x / rng[9]
    assert u @ states[9].P @ u == pytest.approx((rng[9] * (rho - 1) / 2) ** 2)


def test_array_motion_correction_removes_the_moving_array_bias():
    """Delays of the moving array (eq. (M1)): uncorrected they bias the static estimate by
    metres (the cone angle moves by (v/c) cos θ cot θ); corrected (M2, M4) the estimate
    converges to the source as with a static array's delays."""
    tr, el = _geometry()
    tau = _moving(_delays(el, SOURCE), el, SOURCE, _velocity(tr))
    d = {"motion": "static", "range_bank": [1000.0, 20000.0, 6], "sigma_delay_s": 2e-6}
    raw = track_delays(tr.time, tau, None, el, 0, C, d, "ukf", heading_rad=tr.heading)
    cor = track_delays(tr.time, tau, None, el, 0, C, d, "ukf", heading_rad=tr.heading,
                       array_velocity=_velocity(tr))
    e_raw = np.hypot(raw["x"][-1] - SOURCE[0], raw["y"][-1] - SOURCE[1])
    e_cor = np.hypot(cor["x"][-1] - SOURCE[0], cor["y"][-1] - SOURCE[1])
    assert e_cor < 0.3 and e_raw > 10 * e_cor


def test_cv_option_tracks_a_moving_source():
    tr, el = _geometry(dt=5.0)
    state = np.array([2000.0, 1000.0, 0.0, 3.0])             # thesis fig. 3.18 source
    src = S.source_positions(state, tr.time)
    tau = _delays(el, src)
    d = {"motion": "cv", "q": 1e-6, "range_m": 2500.0, "sigma_range_m": 1500.0,
         "sigma_speed_mps": 4.0, "side": "auto", "sigma_delay_s": 1e-6}
    r = track_delays(tr.time, tau, None, el, 0, C, d, "ukf", heading_rad=tr.heading)
    err = np.hypot(r["x"] - src[:, 0], r["y"] - src[:, 1])
    assert err[-1] < 2.0
    assert np.hypot(r["vx"][-1] - 0.0, r["vy"][-1] - 3.0) < 0.05
    # the static model on the same moving source is biased by far more
    rs = track_delays(tr.time, tau, None, el, 0, C, {**d, "motion": "static"}, "ukf",
                      heading_rad=tr.heading)
    assert np.hypot(rs["x"][-1] - src[-1, 0], rs["y"][-1] - src[-1, 1]) > 50 * err[-1]


def test_missing_delays_and_gate():
    tr, el = _geometry()
    tau = _delays(el, SOURCE)
    tau[3, 5:] = np.nan                        # some delays missing
    tau[4, 2:] = np.nan                        # one usable delay only: coast
    tau[40, 1:] += 1e-3                        # an outlier row once the track has settled
    d = {"motion": "static", "range_m": 3000.0, "sigma_range_m": 1500.0,
         "sigma_delay_s": 2e-5, "gate_prob": 0.9999}
    r = track_delays(tr.time, tau, None, el, 0, C, d, "ukf", heading_rad=tr.heading)
    assert r["n_delays"][3] == 4 and r["updated"][3]
    assert not r["updated"][4] and not r["updated"][40]
    assert r["updated"].sum() == tr.time.size - 2
    assert np.hypot(r["x"][-1] - SOURCE[0], r["y"][-1] - SOURCE[1]) < 1.0
    # without the gate the outlier row pulls the estimate
    r0 = track_delays(tr.time, tau, None, el, 0, C, {**d, "gate_prob": 0.0}, "ukf",
                      heading_rad=tr.heading)
    assert r0["updated"][40]
    jump = np.hypot(np.diff(r0["x"]), np.diff(r0["y"]))
    assert jump[39] > 10 * max(jump[38], jump[40])
    with pytest.raises(FormatError, match="no row has two usable"):
        track_delays(tr.time, np.full_like(tau, np.nan), None, el, 0, C, d, "ukf")
    with pytest.raises(FormatError, match="sigma"):
        track_delays(tr.time, tau, None, el, 0, C, {"motion": "static"}, "ukf")


def _toml(tmp_path, body, name="trk.toml"):
    p = tmp_path / name
    p.write_text('[tracker]\nmode = "multi"\nmeasurements = "delays"\n' + body)
    return str(p)


def test_config_errors(tmp_path):
    for body, msg in (('filter = "srf"\n', "filter must be one of"),
                      ('filter = "rpf"\n', "filter must be one of"),
                      ('sigma_bearing_deg = 1.0\n', "unknown key tracker.sigma_bearing_deg"),
                      ('[tracker.delays]\nmotion = "ct"\n', "motion must be"),
                      ('[tracker.delays]\nside = "left"\n', "side must be"),
                      ('[tracker.delays]\nrange_m = 0\n', "range_m must be"),
                      ('[tracker.delays]\ngate_prob = 1.0\n', "gate_prob must be < 1"),
                      ('[tracker.delays]\nfoo = 1\n', "unknown key tracker.delays.foo"),
                      ('[tracker.delays]\nrange_bank = [5000.0, 1000.0, 4]\n', "range_bank"),
                      ('[tracker.delays]\nrange_bank = [500.0, 1000.0, 1.5]\n',
                       "range_bank"),
                      ('[tracker.params]\nalpha = "x"\n', "tracker.params")):
        with pytest.raises(ConfigError, match=msg):
            load_tracker_config(_toml(tmp_path, body))
    cfg = load_delays_config(_toml(tmp_path, 'filter = "ghf"\n[tracker.params]\ngh_order = 4\n'))
    assert cfg["filter"] == "ghf" and cfg["delays"]["motion"] == "static"
    assert load_tracker_config(_toml(tmp_path, ""))["multi"]["measurements"] == "delays"


def test_arrayproc_track_on_delays_products(tmp_path):
    """Products ``delays`` (unsorted rows, the sigma column) + a recording's /nav and array
    geometry → a ``tracks`` group whose last point is the source."""
    fine = S.turn_track(dt=1.0)
    pos = np.zeros((N_H, 3))
    pos[:, 0] = -np.arange(N_H) * DX           # trailing the reference point (body x forward)
    rec = tmp_path / "rec.h5"
    with RecordingWriter(rec, 100.0, N_H, positions=pos) as w:
        w.append(np.zeros((10, N_H), np.float32))
        w.set_nav(fine.time, fine.position, np.rad2deg(fine.heading) % 360.0)
    tr, el = _geometry()
    # the recording's array is at depth 0; the delays a moving array measures (M1), which
    # the tracker corrects by default (array_motion = true, velocity from /nav)
    el[..., 2] = 0.0
    tau = _moving(_delays(el, SOURCE, src_depth=0.0), el, SOURCE, _velocity(tr))
    order = np.r_[np.arange(1, tr.time.size), 0]
    prod = tmp_path / "del.h5"
    with ProductsWriter(prod, source=str(rec)) as w:
        g = w.group("tde", "delays", reference=0)
        g.append(time=tr.time[order], tau=tau[order], sigma=np.full(tau.shape, 2e-6),
                 corr=np.ones(tau.shape))
    out = tmp_path / "trk.h5"
    run_tracker(str(prod), _toml(tmp_path, 'filter = "ckf"\n[tracker.delays]\n'
                                 'range_m = 4000.0\nsigma_range_m = 2500.0\n'), str(out))
    g = read_products(str(out))["tracks"]
    assert g["kind"] == "tracks" and g["attrs"]["measurements"] == "delays"
    assert np.all(g["track_id"] == 1) and np.all(np.diff(g["time"]) > 0)
    assert g["row"][0] == order.size - 1       # the products row of the first time
    assert np.hypot(g["x"][-1] - SOURCE[0], g["y"][-1] - SOURCE[1]) < 0.2
    assert g["attrs"]["array_motion"]
    assert np.allclose(g["own_x"], el[:, 0, 0], atol=1e-6)
    assert g["cov"].shape == (tr.time.size, 4, 4)
    with pytest.raises(FormatError, match="channels"):
        bad = tmp_path / "bad.h5"
        with ProductsWriter(bad, source=str(rec)) as w:
            w.group("tde", "delays", reference=0).append(
                time=tr.time, tau=tau[:, :5], sigma=np.full((tr.time.size, 5), 2e-6),
                corr=np.ones((tr.time.size, 5)))
        run_tracker(str(bad), _toml(tmp_path, ""), str(tmp_path / "t2.h5"))
