"""Bearings resolved to their side by port/starboard beams (``lr_cbf`` → ``bearings`` column
``side``, both bearing columns the one true bearing): the trackers take one hypothesis, the
true side, with no mirror."""

from __future__ import annotations

import math
import os

import numpy as np

from arrayproc.io.products import ProductsWriter, read_products
from arrayproc.track.multi import resolved_side
from arrayproc.track.runner import run_tracker
from tests.track.test_runner import DATA, _write_inputs


def _resolved(tmp_path, g, rng):
    """The same section-V geometry as bearings resolved to their side."""
    theta = np.arctan2(g["rel"][:, 0], g["rel"][:, 1]) + rng.normal(0, math.radians(1.5),
                                                                      g["times"].size)
    d = np.rad2deg(np.angle(np.exp(1j * (theta - g["heading"]))))
    brg = np.mod(np.rad2deg(g["heading"]) + d, 360)
    t = g["times"]
    prod = tmp_path / "resolved.h5"
    rec = tmp_path / "rec.h5"
    with ProductsWriter(prod, source=str(rec)) as w:
        w.group("bearings", "bearings").append(
            time=t, cone_deg=np.abs(d), bearing_port_deg=brg, bearing_stbd_deg=brg,
            level_db=np.full(t.size, 120.0), snr_db=np.full(t.size, 20.0),
            freq_lo=np.full(t.size, 800.0), freq_hi=np.full(t.size, 1200.0),
            spl_db=np.full(t.size, 110.0), rel_bearing_deg=d, side=np.sign(d))
    return prod, np.sign(d)


def test_resolved_side_rule():
    assert resolved_side(None, np.arange(3)) is None
    assert resolved_side(np.array([1.0, -1.0, 0.0]), np.array([0, 1])).tolist() == [1.0, -1.0]
    assert resolved_side(np.array([1.0, 0.0, -1.0]), np.array([0, 1])) is None


def test_single_tracker_on_resolved_bearings_has_no_mirror(tmp_path, rng):
    """Case I of the L-R paper with resolved rows: the UKF with L-R resolution ends within
    1 km of the truth, as with the ambiguous pairs after the manoeuvre, but from one
    hypothesis (the track is the true side's from the first row)."""
    _, _, g = _write_inputs(tmp_path)
    prod, sides = _resolved(tmp_path, g, rng)
    out = tmp_path / "tracks.h5"
    run_tracker(str(prod), os.path.join(DATA, "ukf_lr.toml"), str(out))
    tr = read_products(str(out))["tracks"]
    err = np.hypot(tr["x"] - g["target"][:, 0], tr["y"] - g["target"][:, 1])
    mirror_like = np.hypot(tr["x"][-1] - g["own"][-1, 0], tr["y"][-1] - g["own"][-1, 1])
    assert err[-1] < 1000.0, err[-1]
    assert mirror_like > 2000.0  # not collapsed onto the ownship track between hypotheses


def test_multi_tracker_side_weight_follows_the_resolved_side(tmp_path, rng):
    _, _, g = _write_inputs(tmp_path)
    prod, sides = _resolved(tmp_path, g, rng)
    out = tmp_path / "tracks.h5"
    run_tracker(str(prod), os.path.join(DATA, "multi_target.toml"), str(out))
    tr = read_products(str(out))["tracks"]
    assert np.unique(tr["track_id"]).size >= 1
    w = tr["side_weight"][np.isfinite(tr["side_weight"])]
    assert w.size and set(np.unique(w)) <= {0.0, 1.0}  # the side of each row, not a mixture
    assert {0.0, 1.0} <= set(np.unique(sides > 0).astype(float))  # the target changes side
