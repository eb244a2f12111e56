"""SPL-TMA from a recording (arrayproc.evaluate.spl_recording, docs/validation/spl_recording.md):
the shipped scenario tma_spl_paper through simulate → process (chain spl_tma) → track (RPF,
bearings only and with spl_db), scored against the simulator's truth."""

from __future__ import annotations

import numpy as np

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
    its bearing within 0.3° of the truth (the straight leg: bearing rate 0.01°/s), and both
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
