"""The bearings' ``spl_db`` column is the received level at a hydrophone (simulator truth)."""

from __future__ import annotations

import numpy as np

from arrayproc.chain import build_chain, run_chain
from arrayproc.io.products import ProductsWriter, read_products
from arrayproc.io.recording import Recording
from arrayproc.sim.run import simulate
from arrayproc.sim.scenario import parse_scenario
from tests.conftest import cbf_stage, chain_toml

CHAIN = chain_toml(cbf_stage(2048, [250.0, 800.0], 181), {"type": "integrate", "snapshots": 4},
                   {"type": "bearings", "band": [450.0, 750.0], "lines": True})


def test_spl_matches_the_received_levels(tmp_path):
    """A source 5 km away (spherical spreading): a 300 Hz tonal of SL 150 dB re 1 µPa @ 1 m
    and a 400-800 Hz band of 120 dB re 1 µPa²/Hz @ 1 m, far above the noise. The line's
    spl_db is SL − 20 log10 r; the broadband peak's is the band level over the 450-750 Hz
    bins summed."""
    cone = np.deg2rad(70.0)
    scen = {"recording": {"fs": 2048.0, "duration": 24.0, "seed": 3},
            "array": {"type": "line", "n": 32, "spacing": 0.75, "depth": 50.0},
            "ownship": {"start": [0.0, 0.0], "heading": 0.0},
            "source": [{"name": "s", "start": [5000 * np.sin(cone), 5000 * np.cos(cone)],
                        "depth": 50.0, "tonals": [{"freq": 300.0, "level_db": 150.0}],
                        "broadband": {"band": [400.0, 800.0], "level_db": 120.0}}],
            "noise": {"level_db": 20.0}}
    rec = simulate(parse_scenario(scen, file="spl"), tmp_path / "r.h5")
    with Recording(rec) as r, ProductsWriter(tmp_path / "p.h5") as w:
        run_chain(r, build_chain(CHAIN), w)
    g = read_products(tmp_path / "p.h5")["bearings"]
    main = np.abs(g["cone_deg"] - 70.0) < 1.0
    broad = main & (g["freq_hi"] - g["freq_lo"] > 10)
    line = main & (np.abs(0.5 * (g["freq_lo"] + g["freq_hi"]) - 300.0) < 0.6)
    assert broad.sum() >= 4 and line.sum() >= 4
    tonal_rl = 150.0 - 20 * np.log10(5000.0)
    n_bins = 301  # 450..750 Hz at 1 Hz
    band_rl = 120.0 - 20 * np.log10(5000.0) + 10 * np.log10(n_bins)
    assert np.all(np.abs(g["spl_db"][line] - tonal_rl) < 0.2)
    assert np.all(np.abs(g["spl_db"][broad] - band_rl) < 1.0)
