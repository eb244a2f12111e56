"""Multi mode on ``positions`` rows (compact-array TDOA fixes): 3-D constant-velocity tracks
with each row's covariance; two sources, sporadic outliers."""

from __future__ import annotations

import numpy as np

from arrayproc.io.products import ProductsWriter, read_products
from arrayproc.track.manage.tracks import status_names
from arrayproc.track.runner import run_tracker


def test_two_sources_3d(tmp_path):
    rng = np.random.default_rng(2)
    src = [(np.array([100.0, 200.0, 30.0]), np.array([1.0, 0.0, 0.0])),
           (np.array([-150.0, 50.0, 10.0]), np.array([0.0, -0.5, 0.1]))]
    cols = {k: [] for k in ("time", "x", "y", "z", "cov", "tdoa_rms_s", "n_used")}
    for t in np.arange(0.0, 60.0, 2.0):
        pts = [p + v * t + rng.standard_normal(3) * 2.0 for p, v in src if rng.random() < 0.9]
        if rng.random() < 0.2:
            pts.append(rng.uniform(-500, 500, 3))  # a false fix
        for q in pts:
            cols["time"].append(t)
            for i, k in enumerate("xyz"):
                cols[k].append(q[i])
            cols["cov"].append(4.0 * np.eye(3))
            cols["tdoa_rms_s"].append(1e-5)
            cols["n_used"].append(6)
    prod = tmp_path / "p.h5"
    with ProductsWriter(prod) as w:
        w.group("localise", "positions").append(**{k: np.array(v) for k, v in cols.items()})
    cfg = tmp_path / "c.toml"
    cfg.write_text('[tracker]\nmode = "multi"\nmeasurements = "positions"\n'
                   '[tracker.positions]\nq = 0.01\nsigma_speed_mps = 3.0\n')
    out = tmp_path / "t.h5"
    run_tracker(str(prod), str(cfg), str(out))
    g = read_products(str(out))["tracks"]
    st = status_names(g["status"])
    ids = np.unique(g["track_id"][st == "confirmed"])
    assert len(ids) == 2
    for tid, (p, v) in zip(sorted(ids, key=lambda i: g["x"][g["track_id"] == i][-1]),
                           sorted(src, key=lambda s: (s[0] + s[1] * 58)[0]), strict=True):
        m = (g["track_id"] == tid) & (st == "confirmed")
        last = np.flatnonzero(m)[-1]
        truth = p + v * g["time"][last]
        assert np.linalg.norm([g["x"][last] - truth[0], g["y"][last] - truth[1],
                               g["z"][last] - truth[2]]) < 6.0
