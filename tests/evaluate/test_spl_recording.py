"""SPL-TMA from a recording (arrayproc.evaluate.spl_recording, docs/validation/spl_recording.md):
the shipped scenario tma_spl_paper through simulate → process (chain spl_tma) → track (RPF,
bearings only and with spl_db), scored against the simulator's truth."""

from __future__ import annotations

import numpy as np
import pytest

from arrayproc.config import parse_toml
from arrayproc.evaluate.spl_recording import run_seed, summarise, tracker_toml
from arrayproc.track.single import check_single_config


def test_tracker_configs_are_valid():
    """The two generated tracker files pass the tracker's own checks; only the levels one
    reads spl_db."""
    for levels in (False, True):
        cfg = check_single_config(parse_toml(tracker_toml(levels, 100, 3), "t")["tracker"], "t")
        assert cfg["filter"] == "rpf" and cfg["params"]["seed"] == 3
        assert ("level" in cfg) is levels


def test_short_recording_products_and_tracks(tmp_path):
    """Four minutes of the first leg, one seed: every 60-s row's level is within 0.4 dB and
    its bearing within 0.3° of the truth (the straight leg: bearing rate 0.01°/s), the
    bearing error within 0.08° of the one the arrival's elevation gives, and both
    trackers give a track on every row whose error shrinks from the prior's (~5 km)."""
    r = run_seed(7, str(tmp_path), duration=240.0, particles=1000)
    assert r["time"].size == 4
    assert not (tmp_path / "rec_7.h5").exists()
    assert np.all(np.abs(r["level_err_db"]) < 0.4)
    assert np.all(np.abs(r["bearing_err_deg"]) < 0.3)
    assert np.all(r["true_side"] == -1)         # the target is on the port side of the leg
    for label in ("bot", "spl"):
        e = r[f"err_{label}_m"]
        assert np.all(np.isfinite(e))
        assert e[-1] < e[0] < 6000.0
    s = summarise([r])
    assert abs(s["level_err_mean_db"]) < 0.4 and s["bearing_err_std_deg"] < 0.1
    # the bearing error is the arrival's elevation (−0.06…−0.07°) within 0.08°
    beyond = r["bearing_err_deg"] - np.asarray(s["sweeps"]["elevation_bearing_err_deg"])
    assert np.all(np.abs(beyond) < 0.08)
    assert list(s["segments"]) == ["first leg (0-13 min)"]
    assert s["segments"]["first leg (0-13 min)"]["rows"] == 4


def _recordings(tmp_path_factory, n: int = 8) -> dict:
    from arrayproc.evaluate.spl_recording import measurement_level

    wd = str(tmp_path_factory.mktemp("spl"))
    s = summarise([run_seed(seed, wd, particles=5000) for seed in range(1, n + 1)])
    s["mc_paper"] = measurement_level(300, 5000, 1)
    s["mc_recording"] = measurement_level(
        300, 5000, 1, sigma_bearing_deg=s["bearing_err_residual_std_deg"],
        sigma_level_db=s["level_err_residual_std_db"],
        offsets=(s["time_s"], s["bearing_err_mean_by_time_deg"], s["level_err_mean_by_time_db"]))
    return s


@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    return _recordings(tmp_path_factory)


def _final(s: dict, mc: dict, label: str) -> tuple[float, float]:
    """The recording's RMSE at its last row (29.5 min) and the Monte Carlo's there."""
    t = s["time_min"][-1]
    return s[f"rmse_{label}_m"][-1], float(np.interp(t, mc["time_min"], mc[f"rmse_{label}_m"]))


@pytest.mark.slow
def test_recording_errors_explain_its_rmse(recordings):
    """Eight full recordings: on the straight first leg the products are within a fraction of
    the paper's σ's (levels +0.08 ± 0.16 dB, bearings −0.13 ± 0.04° measured on 50 seeds); the
    measurement-level Monte Carlo given the recordings' mean errors at each time and their
    residual σ reproduces the recordings' final RMSE within 30 % for both filters; on the legs
    the mean bearing error is within 0.4° of the elevation's (cos θc = cos β cos φ)."""
    s = recordings
    leg = s["segments"]["first leg (0-13 min)"]
    assert abs(leg["level_err_mean_db"]) < 0.3 and leg["level_err_std_db"] < 0.3
    assert abs(leg["bearing_err_mean_deg"]) < 0.25 and leg["bearing_err_std_deg"] < 0.1
    assert s["level_err_residual_std_db"] < 0.2 and s["bearing_err_residual_std_deg"] < 0.5
    # on the legs the bearing error is the arrival's elevation (cone angle read as bearing):
    # measured 0.10° (first leg) and 0.33° (second) at most beyond it on 50 seeds
    tm = np.asarray(s["time_min"])
    legs = (tm < 13.0) | (tm >= 17.0)
    beyond = np.asarray(s["bearing_err_mean_by_time_deg"]) - np.asarray(
        s["sweeps"]["elevation_bearing_err_deg"])
    assert np.all(np.abs(beyond[legs]) < 0.4)
    for label in ("bot", "spl"):
        rec, mc = _final(s, s["mc_recording"], label)
        assert abs(rec / mc - 1.0) < 0.3, (label, rec, mc)


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="measured on 50 recordings (docs/validation/"
                   "spl_recording.md): final RMSE bearings-only 301.8 m = 1.61x the paper-σ "
                   "Monte Carlo's 186.9 m, with levels 149.2 m = 1.30x its 115.0 m; the "
                   "products' bearings carry the arrival's elevation (the line array's cone "
                   "angle read as a horizontal bearing: -0.64° mean on the second leg, to "
                   "-1.32°) and, in the turn, errors of the 60-s integration (to +7.1°)")
def test_recording_matches_measurement_level(recordings):
    """Target: from recordings, both filters' final RMSE within 20 % of the measurement-level
    Monte Carlo with the paper's σ's."""
    for label in ("bot", "spl"):
        rec, mc = _final(recordings, recordings["mc_paper"], label)
        assert rec <= 1.2 * mc, (label, rec, mc)


def test_shipped_trackers_are_the_evaluated_ones():
    """arrayproc/data/trackers/rpf_{spl,bot}.toml hold the tracker the evaluation runs."""
    from arrayproc.data import data_path

    for name, levels in (("rpf_spl", True), ("rpf_bot", False)):
        text = data_path("trackers", f"{name}.toml").read_text(encoding="utf-8")
        assert parse_toml(text, name) == parse_toml(tracker_toml(levels, 5000, 0), name)
