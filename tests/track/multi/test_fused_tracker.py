"""The fused multi-target tracker (``measurements = "fused_bearings"``): two static compact
arrays' azimuths in one tracker, two vessels (arrayproc.evaluate.scenarios.fused_tracker)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from arrayproc.app.cli import main
from arrayproc.data import data_path
from arrayproc.evaluate.scenarios.fused_tracker import (
    SITES,
    run_fused_case,
    write_fused_case,
)
from arrayproc.io.products import read_products
from arrayproc.track.multi.fused import cross_fix_point

FUSED = str(data_path("trackers", "compact_fused.toml"))


def _track(inputs: list[str], config: str, output: str) -> None:
    assert main(["track", *inputs, "-c", config, "-o", output, "-q"]) == 0


def test_cross_fix_point_and_its_covariance():
    a, b = np.array([0.0, 0.0]), np.array([1000.0, 0.0])
    target = np.array([500.0, 500.0])
    ba, bb = math.atan2(500, 500), math.atan2(-500, 500)  # rays crossing at 90°
    p, C = cross_fix_point(a, ba, b, bb, math.radians(1.0), math.radians(10), 1e4)
    assert np.allclose(p, target)
    # each bearing moves the fix by r σ / sin γ along the other ray (γ = 90°, r = 707 m)
    s = math.hypot(500, 500) * math.radians(1.0)
    assert np.allclose(np.linalg.eigvalsh(C), [s * s, s * s], rtol=1e-4)
    # near-parallel, diverging and too distant rays start nothing
    assert cross_fix_point(a, 0.0, b, math.radians(5), 0.01, math.radians(10), 1e4) is None
    assert cross_fix_point(a, -ba, b, -bb, 0.01, math.radians(10), 1e4) is None
    assert cross_fix_point(a, ba, b, bb, 0.01, math.radians(10), 500.0) is None


def test_two_vessels_two_seeds_through_the_command(tmp_path):
    """Fast form of the slow multi-seed test: 2 seeds, both vessels held, NEES in band."""
    r = run_fused_case([0, 1], FUSED, _track)
    lo, hi = r["nees_band"]
    for v in r["vessels"]:
        assert v["held_min"] >= 0.9
        assert v["rmse_m"] < 100.0
        assert lo <= v["nees"] <= hi
    assert r["false_max"] <= 1


def test_tracks_file_names_its_arrays(tmp_path):
    paths = write_fused_case(tmp_path, np.random.default_rng(3), duration=120.0)
    out = str(tmp_path / "t.h5")
    _track(paths, FUSED, out)
    prod = read_products(out)
    g = prod["tracks"]
    assert np.allclose(np.c_[g["attrs"]["array_x_m"], g["attrs"]["array_y_m"]], SITES)
    arr = np.asarray(g["array"])
    assert g["attrs"]["filter"] == "ekf"
    assert set(np.unique(arr)) <= {-1, 0, 1} and {0, 1} <= set(np.unique(arr))
    az = np.asarray(g["meas_azimuth_deg"])
    assert np.all(np.isnan(az[arr < 0])) and np.all(np.isfinite(az[arr >= 0]))
    assert len(str(prod["/"]["products"]).splitlines()) == 2


@pytest.mark.parametrize("config, n, msg", [
    ("compact_multi.toml", 2, "reads one products file; 2 were given"),
    ("compact_fused.toml", 1, "reads two or more products files"),
])
def test_input_count_refused(tmp_path, capsys, config, n, msg):
    paths = write_fused_case(tmp_path, np.random.default_rng(0), duration=30.0)[:n]
    rc = main(["track", *paths, "-c", str(data_path("trackers", config)), "-o",
               str(tmp_path / "t.h5"), "-q"])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and msg in err and len(err.splitlines()) == 1
    assert not (tmp_path / "t.h5").exists()


@pytest.mark.slow
def test_two_vessels_twenty_seeds():
    """20 seeds (scripts/validate_fused_tracker.py): each vessel held ≥ 90 % on average, the
    position NEES in its 95 % band, at most 0.5 false tracks per seed."""
    r = run_fused_case(list(range(20)), FUSED, _track)
    lo, hi = r["nees_band"]
    for v in r["vessels"]:
        assert v["held"] >= 0.9
        assert lo <= v["nees"] <= hi
    assert r["false_per_seed"] <= 0.5


def test_tma_cross_fix_on_one_fused_tracks_file(tmp_path):
    """``tma -c cross_fix`` on the fused tracks file: one solution per confirmed track, each
    within 3σ (its covariance) of its vessel's state at the window start."""
    from arrayproc.evaluate.scenarios.fused_tracker import vessel_truth

    paths = write_fused_case(tmp_path, np.random.default_rng(0))
    trk, out = str(tmp_path / "t.h5"), str(tmp_path / "tma.h5")
    _track(paths, FUSED, trk)
    assert main(["tma", trk, "-c", str(data_path("tma", "cross_fix.toml")), "-o", out,
                 "-q"]) == 0
    g = read_products(out)["tma"]
    X = np.c_[g["x"], g["y"], g["vx"], g["vy"]]
    assert X.shape[0] == 2
    for x, t0, C in zip(X, np.asarray(g["t0"]), np.asarray(g["cov"]), strict=True):
        truth = vessel_truth(np.array([t0]))[:, 0]
        k = int(np.argmin(np.hypot(*(truth[:, :2] - x[:2]).T)))
        z = (x - truth[k]) / np.sqrt(np.diag(C))
        assert np.all(np.abs(z) < 3.0), z
