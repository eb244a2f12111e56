"""``arrayproc tma TRK_A.h5 TRK_B.h5 -c cross_fix``: two vessels seen by two static compact
arrays 800 m apart (one azimuth row of each per 4 s scan, σ 1°), each array's rows tracked by
the shipped compact multi-target tracker; the tracks are paired across the arrays by their
joint fit's cost per degree of freedom and each pair solved within 3σ of its CRLB (seed 0:
the right pairs cost 0.95 and 1.18 per degree of freedom, the wrong ones 775 and 3025)."""
from __future__ import annotations

import numpy as np
import pytest

from arrayproc.app.cli import main
from arrayproc.data import data_path
from arrayproc.evaluate.scenarios.two_array_fusion import write_array_products
from arrayproc.io.products import read_products
from arrayproc.track.batch.bo_tma import bearing_model
from arrayproc.track.batch.cross_fix_tracks import difference_sigma
from arrayproc.track.runner import run_tracker

SITES = np.array([[0.0, 0.0], [800.0, 0.0]])
TARGETS = np.array([[-2000.0, 600.0, 7.3, 0.0], [1500.0, -1800.0, -3.0, 5.0]])
TIMES = np.arange(0.0, 540.0 + 1e-9, 4.0)
SIGMA_DEG = 1.0
CROSS_FIX = f"{data_path('tma')}/cross_fix.toml"


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    d = tmp_path_factory.mktemp("xf_tracks")
    rng = np.random.default_rng(0)
    out = {"dir": d}
    for name, site in zip("AB", SITES, strict=True):
        az = np.stack([np.rad2deg(bearing_model(x, TIMES, np.tile(site, (TIMES.size, 1))))
                       + rng.normal(0.0, SIGMA_DEG, TIMES.size) for x in TARGETS])
        prod = write_array_products(d, name, site, TIMES, az)
        trk = d / f"{name}_trk.h5"
        run_tracker(prod, f"{data_path('trackers')}/compact_multi.toml", str(trk))
        out[name], out[f"{name}_prod"] = trk, prod
    return out


def test_difference_sigma_is_the_white_noise():
    rng = np.random.default_rng(4)
    t = np.arange(0.0, 1200.0, 4.0)
    y = bearing_model(TARGETS[0], t, np.zeros((t.size, 2))) + rng.normal(0, 0.02, t.size)
    assert difference_sigma(t, y) == pytest.approx(0.02, rel=0.12)


def test_tracks_paired_across_arrays_within_3_sigma(scene, capsys):
    out = scene["dir"] / "tma.h5"
    assert main(["tma", str(scene["A"]), str(scene["B"]), "-c", CROSS_FIX, "-o", str(out),
                 "-q"]) == 0, capsys.readouterr().err
    g = read_products(str(out))["tma"]
    assert g["x"].size == 2 and set(g["method"]) == {b"cross_fix"}
    found = set()
    for i in range(2):
        est = np.array([g["x"][i], g["y"][i], g["vx"][i], g["vy"][i]])
        sig = np.sqrt(np.diag(g["crlb"][i]))
        truth = [x + np.r_[x[2:] * g["t0"][i], 0.0, 0.0] for x in TARGETS]
        z = [np.abs(est - x) / sig for x in truth]
        k = int(np.argmin([v.max() for v in z]))
        assert np.all(z[k] < 3.0), (i, z[k])
        assert np.all(z[1 - k] > 30.0)            # far from the other vessel
        found.add(k)
    assert found == {0, 1}                        # one solution per vessel
    assert sorted(g["track_id"]) == [0, 1] and sorted(g["pair_track_id"]) == [0, 1]


@pytest.mark.parametrize("case", ["mixed", "three"])
def test_tracks_refusals(scene, tmp_path, capsys, case):
    inputs = ([scene["A"], scene["B_prod"]] if case == "mixed"
              else [scene["A"], scene["B"], scene["A"]])
    out = tmp_path / "out.h5"
    rc = main(["tma", *map(str, inputs), "-c", CROSS_FIX, "-o", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and err[0].startswith("arrayproc: error:"), err
    assert ("not both" if case == "mixed" else "two tracks files") in err[0], err[0]
    assert not out.exists() and list(tmp_path.iterdir()) == []
