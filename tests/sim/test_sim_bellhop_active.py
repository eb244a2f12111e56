"""``multipath = "bellhop"`` for active echoes: every transmit × receive eigenray pair is one
echo path (delay τ₁ + τ₂, amplitude A₁A₂), against the image-source echo of the same
waveguide (pressure-release surface, impedance-matched bottom: the four surface paths)."""

from __future__ import annotations

import numpy as np
import pytest

from arrayproc.sim.scenario import parse_scenario

pytest.importorskip("whoi_uwapm")

C, FS = 1500.0, 5120.0
R0, ZT, ZR = 500.0, 50.0, 30.0


def echo_scenario(prop: dict) -> object:
    return parse_scenario({
        "recording": {"fs": FS, "duration": 0.2 + 2 * R0 / C + 0.6, "sound_speed": C,
                      "seed": 1},
        "array": {"type": "line", "n": 1, "spacing": 1.0, "depth": ZR},
        "ownship": {"start": [0.0, 0.0], "heading": 0.0},
        "propagation": prop,
        "active": {"waveform": "hfm", "f0": 1000.0, "f1": 2000.0, "duration": 0.2,
                   "level_db": 200.0, "interval": 100.0, "first": 0.1, "count": 1,
                   "offset": [0.0, 0.0, 0.0], "direct": False, "taper": 0.1,
                   "target": [{"name": "t", "start": [0.0, R0], "depth": ZT, "heading": 0.0,
                               "ts_db": 0.0}]},
    })


def test_bellhop_echo_matches_image_echo_over_surface_paths():
    from arrayproc.sim.run import Simulator

    bh = Simulator(echo_scenario({"multipath": "bellhop", "bellhop": {
        "depth": 100.0, "max_range": 600.0, "range_step": 5.0, "n_beams": 2000,
        "bottom_speed": C, "bottom_density": 1.0, "bottom_atten": 0.0}}))
    im = Simulator(echo_scenario({"multipath": {"surface": True, "order": 1}}))
    assert bh.bellhop_runs.n_runs == 1  # one run (target depth) serves both legs
    recv, trans = bh.active.bellhop.legs(ZT)
    i = int(round(R0 / 5.0)) - 1
    delays = np.sort(recv.stacked[:, i, 0])
    geo = np.hypot(R0, [ZT - ZR, ZT + ZR]) / C
    xb = bh.render(0, bh.n_samples)[:, 0].astype(float)
    xi = im.render(0, im.n_samples)[:, 0].astype(float)
    n = 2 * xb.size
    f = np.fft.rfftfreq(n, 1 / FS)
    band = (f > 1100.0) & (f < 1900.0)
    xb_f, xi_f = np.fft.rfft(xb, n)[band], np.fft.rfft(xi, n)[band]
    err = np.abs(xb_f - xi_f).max() / np.abs(xi_f).max()
    lev = 10 * np.log10(np.sum(xb ** 2) / np.sum(xi ** 2))
    print(f"BELLHOP echo vs image echo: max |X_bh − X_img| / max |X_img| = {err:.2e} over "
          f"1.1-1.9 kHz, energy {lev:+.4f} dB; family delays − slant/c at {R0:g} m: "
          f"{(delays - geo) * 1e9} ns")
    assert delays.size == 2 and np.all(np.abs(delays - geo) < 1e-6)
    assert err < 0.01 and abs(lev) < 0.05
