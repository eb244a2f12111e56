"""Water-pulled (threaded) towed array: the shape in a turn against the circle the tow path
draws, the rigid layout on a straight leg, and the field received on the bent shape."""

from __future__ import annotations

import numpy as np
import pytest

from arrayproc.errors import ConfigError
from arrayproc.sim.run import Simulator
from arrayproc.sim.scenario import parse_scenario
from arrayproc.sim.sources import tonal_amplitude

C = 1500.0
V = 2.5  # m/s
RATE = 1.0  # deg/s


def turn_scenario(shape: str = "water_pulled", n: int = 32, spacing: float = 1.5,
                  source: dict | None = None, duration: float = 200.0) -> dict:
    src = source or {"start": [3000.0, 2000.0], "depth": 60.0, "heading": 0.0,
                     "tonals": [{"freq": 300.0, "level_db": 150.0, "phase_deg": 0.0}]}
    return {
        "recording": {"fs": 1024.0, "duration": duration, "sound_speed": C, "seed": 2,
                      "truth_interval": 1.0},
        "array": {"type": "line", "n": n, "spacing": spacing, "depth": 60.0, "shape": shape},
        "ownship": {"start": [0.0, 0.0], "leg": [
            {"course": 90.0, "speed": V, "duration": 60.0},
            {"course": 270.0, "speed": V, "duration": 400.0, "turn_rate": RATE,
             "turn": "starboard"}]},
        "source": [{"name": "s", **src}],
    }


def test_shape_in_a_turn_is_the_tow_path_circle():
    """During a steady starboard turn of radius R = v/ω every element lies on the circle the
    reference point draws, at arc distance x (its body x) from it; on the straight leg before
    the turn the shape is the rigid line."""
    sim = Simulator(parse_scenario(turn_scenario()))
    g, a = sim.truth()
    assert a["array"]["shape"] == "water_pulled"
    tt = g["array"]["shape_time"]
    ep = g["array"]["element_positions"]
    body = sim.body
    omega = np.deg2rad(RATE)
    radius = V / omega
    # the turn starts at t = 60 s at (150, 0) on course 90: centre (150, −R) (starboard)
    centre = np.array([V * 60.0, -radius])
    t_in = (tt > 60.0 + (body[:, 0].max() - body[:, 0].min()) / V + 1) & (tt < 200.0)
    err_c = []
    for k in np.flatnonzero(t_in):
        phi_ref = np.pi / 2 - omega * (tt[k] - 60.0)  # angle of the reference point (from x)
        phi = phi_ref - body[:, 0] / radius  # forward elements further along the circle
        cf = centre + radius * np.column_stack([np.cos(phi), np.sin(phi)])
        err_c.append(np.abs(ep[k, :, :2] - cf).max())
    straight = tt < 60.0 - (body[:, 0].max()) / V - 1
    rigid = [sim.pose(np.array([t])) for t in tt[straight]]
    err_s = max(np.abs(ep[k, :, 0] - (r.rpos[0, 0] + body[:, 0] * r.sin_h[0])).max()
                for k, r in zip(np.flatnonzero(straight), rigid))
    # the bend is real: the chord of the array is shorter than its length, the sagitta large
    sag = radius * (1 - np.cos((body[:, 0].max() - body[:, 0].min()) / (2 * radius)))
    print(f"water-pulled shape in a {RATE:g} deg/s turn (R = {radius:.1f} m, array "
          f"{np.ptp(body[:, 0]):.1f} m, sagitta {sag:.2f} m): max distance from the tow-path "
          f"circle {max(err_c):.2e} m over {len(err_c)} truth times; straight leg vs rigid "
          f"{err_s:.2e} m")
    assert len(err_c) > 100 and max(err_c) < 1e-6
    assert err_s < 1e-9
    assert sag > 1.0
    assert np.allclose(ep[:, :, 2], 60.0)


def test_field_on_the_bent_array_matches_its_geometry():
    """Static tonal source: each channel receives A/r·cos(2πf(t − r/c)) with r the distance
    from the truth element positions (the kernel places the elements where the truth says)."""
    f = 300.0
    sim = Simulator(parse_scenario(turn_scenario()))
    k0 = int(150.0 * sim.fs)
    n = 256
    x = sim.render(k0, k0 + n).astype(float)
    t = (k0 + np.arange(n)) / sim.fs
    epos = sim.own.threaded(t, sim.body, np.zeros(n))
    r = np.linalg.norm(epos - np.array([3000.0, 2000.0, 60.0]), axis=2)
    ref = tonal_amplitude(150.0) / r * np.cos(2 * np.pi * f * (t[:, None] - r / C))
    err = np.abs(x - ref).max() / np.abs(ref).max()
    # rigid array at the same time: the bend is visible in the field
    rig = Simulator(parse_scenario(turn_scenario("rigid"))).render(k0, k0 + n).astype(float)
    diff = np.abs(rig - ref).max() / np.abs(ref).max()
    print(f"bent array field vs closed form: max rel. error {err:.1e}; rigid array differs "
          f"by {diff:.2f} of the amplitude")
    assert err < 2e-3  # the fractional-delay interpolator's pass-band error is < -60 dB
    assert diff > 0.1


def test_water_pulled_needs_a_moving_ownship():
    d = turn_scenario()
    d["ownship"] = {"start": [0.0, 0.0], "heading": 0.0}
    with pytest.raises(ConfigError, match="water_pulled"):
        parse_scenario(d)
