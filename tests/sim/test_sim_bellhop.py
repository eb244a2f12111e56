"""``multipath = "bellhop"``: the simulated tonal level from BELLHOP's arrivals (ray families
interpolated in range, each with its own delay and phase) against BELLHOP's own coherent TL."""

from __future__ import annotations

import numpy as np
import pytest

from arrayproc.errors import ConfigError
from arrayproc.sim.scenario import parse_scenario
from arrayproc.sim.sources import tonal_amplitude

pytest.importorskip("whoi_uwapm")

F, FS = 500.0, 2048.0
ZS, ZR, D = 20.0, 40.0, 100.0
BH = {"depth": D, "freq": F, "max_range": 2700.0, "range_step": 5.0, "bottom_speed": 1700.0,
      "bottom_density": 1.8, "bottom_atten": 0.5}


def scenario(ranges, extra=None) -> dict:
    return {"recording": {"fs": FS, "duration": 3.0, "seed": 1},
            "array": {"type": "positions", "positions": [[r, 0.0, 0.0] for r in ranges],
                      "depth": ZR},
            "source": [{"name": "s", "start": [0.0, 0.0], "depth": ZS, "heading": 0.0,
                        "tonals": [{"freq": F, "level_db": 120.0, "phase_deg": 0.0}]}],
            "propagation": {"multipath": "bellhop", "bellhop": dict(BH, **(extra or {}))}}


def test_arrivals_mode_against_bellhop_coherent_tl_at_5_ranges():
    from arrayproc.acoustics.tl.bellhop import run_bellhop
    from arrayproc.sim.bellhop_paths import environment
    from arrayproc.sim.run import Simulator

    ranges = np.array([153.0, 407.0, 811.0, 1493.0, 2507.0])  # off the 5 m arrivals grid
    scen = parse_scenario(scenario(ranges))
    sim = Simulator(scen)
    n, k0 = 2048, 4096
    x = sim.render(k0, k0 + n).astype(float)
    t = (k0 + np.arange(n)) / FS
    ph = 2 * np.mean(x * np.exp(-2j * np.pi * F * t)[:, None], axis=0)
    tl_sim = -20 * np.log10(np.abs(ph) / tonal_amplitude(120.0))
    env = environment(scen.propagation.bellhop, scen.sound_speed, ZS, ZR)
    env.run_type, env.ranges_m = "C", ranges
    tl_bh = run_bellhop(env)(ranges, ZS, ZR)
    fam = sim.bellhop[ZS]
    print(f"BELLHOP arrivals mode ({len(fam.keys)} ray families, 5 m grid) vs BELLHOP "
          "coherent TL:")
    for r, a, b in zip(ranges, tl_sim, tl_bh):
        print(f"  {r:7.0f} m: simulated {a:6.2f} dB, BELLHOP 'C' {b:6.2f} dB ({a - b:+.2f})")
    assert np.all(np.abs(tl_sim - tl_bh) < 0.5)


def test_bellhop_keys_are_checked():
    # without [propagation.bellhop]: the bundled TL tables' Munk environment, the loudest
    # tonal's frequency, the range from the geometry (resolved by the simulator)
    spec = parse_scenario(dict(scenario([100.0]), propagation={"multipath": "bellhop"}))
    bh = spec.propagation.bellhop
    assert bh.depth == 1000.0 and bh.ssp.shape == (7, 2) and bh.freq == F
    assert bh.max_range is None
    with pytest.raises(ConfigError, match="ssp"):
        parse_scenario(scenario([100.0], {"ssp": [[0.0, 1500.0], [50.0, 1490.0]]}))
    with pytest.raises(ConfigError, match="bottom depth"):
        d = scenario([100.0])
        d["propagation"]["bellhop"] = {"ssp": [[0.0, 1500.0], [100.0, 1490.0]]}
        parse_scenario(d)
    d = scenario([100.0])  # active echoes are accepted in the BELLHOP mode
    d["active"] = {"waveform": "cw", "fc": 500.0, "duration": 0.1, "level_db": 200.0,
                   "interval": 10.0}
    assert parse_scenario(d).propagation.bellhop is not None
