"""End to end: a simulated triplet array (``[array] type = "triplet"``) with a broadband source
on the starboard side, through ``lr_cbf`` → ``integrate`` → ``btr`` + ``bearings``: the source
stands ≥ 10 dB above its mirror in the BTR at the design frequency band, and every bearing of
it is resolved to starboard (one true bearing, no mirror)."""

from __future__ import annotations

import numpy as np

from arrayproc.chain import build_chain, run_chain
from arrayproc.evaluate.chains import chain_toml
from arrayproc.evaluate.scenarios.beamformers import LR_TRIPLET_SCENARIO
from arrayproc.io.products import ProductsWriter, read_products
from arrayproc.io.recording import Recording
from arrayproc.io.truth import relative_bearings
from arrayproc.plots.btr import plot_btr
from arrayproc.sim.run import simulate_file


def test_triplet_source_resolved_to_its_side(tmp_path):
    scen = tmp_path / "s.toml"
    scen.write_text(LR_TRIPLET_SCENARIO)
    rec_path = tmp_path / "r.h5"
    simulate_file(scen, rec_path)
    spec = build_chain(chain_toml(
        {"type": "lr_cbf", "band": [800.0, 1200.0], "weights": "cardioid"},
        {"type": "integrate", "snapshots": 8},
        {"type": "btr"},
        {"type": "bearings", "min_separation": 0.0, "peak_widths": 1.0, "max_peaks": 1}))
    prod = tmp_path / "p.h5"
    with Recording(rec_path) as rec, ProductsWriter(prod, source=str(rec_path)) as w:
        run_chain(rec, spec, w)
    g = read_products(prod)
    rel = 90.0 - 30.0  # source due east, array heading 30° → 60° to starboard
    btr = g["btr"]
    ax = btr["cone_deg"]
    look, mirror = np.argmin(np.abs(ax - rel)), np.argmin(np.abs(ax + rel))
    rej = btr["power_db"][:, look] - btr["power_db"][:, mirror]
    assert np.all(rej >= 10.0), rej
    b = g["bearings"]
    assert np.all(b["side"] == 1.0)
    assert np.all(np.abs(b["rel_bearing_deg"] - rel) < 1.0)
    assert np.all(np.abs(b["bearing_stbd_deg"] - 90.0) < 1.0)
    assert np.array_equal(b["bearing_port_deg"], b["bearing_stbd_deg"])
    with Recording(rec_path) as rec:  # the truth on the same axis, for the BTR plot
        truth = relative_bearings(rec, btr["time"])["target"]
    assert np.all(np.abs(truth - rel) < 0.1)
    assert btr["attrs"]["beam_mode"] == "lr"
    png = tmp_path / "btr.png"
    plot_btr(str(prod), str(png))
    assert png.stat().st_size > 10_000
