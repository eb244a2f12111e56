"""End to end: simulated towed array -> shipped ``towed_passive`` chain -> one ``lines`` contact
at each source tonal (Doppler-shifted truth frequency) within 0.5 bin, on its cone angle.

Scenario (below): 32 hydrophones 0.75 m apart towed east at 5 kn, 40 s; two moving sources
with two tonals each, every tonal 5 dB above the noise in a 1 Hz band per hydrophone at the
start range (about 18 dB over the TPSW background after the 15 dB array gain and the Hann
window's 1.8 dB noise bandwidth).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from arrayproc.chain import run_chain
from arrayproc.data import data_path
from arrayproc.io.products import ProductsWriter, read_products
from arrayproc.io.recording import Recording
from arrayproc.io.truth import cone_angles, tonal_frequencies
from arrayproc.stages import load_chain

CHAIN = data_path("chains", "towed_passive.toml")
NL = 60.0  # noise spectral level, dB re 1 µPa²/Hz
# (name, cone at start (deg, + starboard), range (m), course (deg), speed (kn), tonals Hz)
SOURCES = [("alpha", 70.0, 2000.0, 30.0, 6.0, (212.0, 517.0)),
           ("bravo", -120.0, 2500.0, 250.0, 5.0, (333.0, 781.0))]


def scenario(duration: float) -> str:
    parts = [f"""
[recording]
fs = 2048.0
duration = {duration}
sound_speed = 1500.0
seed = 5

[array]
type = "line"
n = 32
spacing = 0.75
depth = 60.0

[ownship]
start = [0.0, 0.0]
[[ownship.leg]]
course = 90.0
speed_kn = 5.0
duration = {duration + 10.0}

[propagation]
loss = "spherical"

[noise]
level_db = {NL}
"""]
    for name, cone, r, course, kn, tonals in SOURCES:
        brg = math.radians(90.0 + cone)
        x, y = r * math.sin(brg), r * math.cos(brg)
        level = NL + 5.0 + 20 * math.log10(r)
        tl = ", ".join(f"{{ freq = {f}, level_db = {level:.2f} }}" for f in tonals)
        parts.append(f"""
[[source]]
name = "{name}"
start = [{x:.1f}, {y:.1f}]
depth = 50.0
course = {course}
speed_kn = {kn}
tonals = [{tl}]
""")
    return "".join(parts)


def test_a_line_contact_at_each_tonal(tmp_path: Path):
    from arrayproc.sim.run import simulate_file
    scen = tmp_path / "scen.toml"
    scen.write_text(scenario(40.0))
    rec_path = tmp_path / "rec.h5"
    simulate_file(scen, rec_path)
    prod = tmp_path / "prod.h5"
    spec = load_chain(str(CHAIN))
    with Recording(rec_path) as rec, ProductsWriter(prod, source=str(rec_path),
                                                    chain=spec.text) as w:
        run_chain(rec, spec, w)
    g = read_products(prod)
    lines = g["lines"]
    df = float(np.median(np.diff(g["lofar"]["freq"])))
    times = np.unique(g["lofar"]["time"])
    assert times.size >= 15  # 2 s integrated snapshots over 40 s
    with Recording(rec_path) as rec:
        freqs = tonal_frequencies(rec, times)
        cones = cone_angles(rec, times)
    for name, *_, tonals in SOURCES:
        for k in range(len(tonals)):
            for i, t in enumerate(times):
                m = (lines["time"] == t) & (np.abs(lines["freq_hz"] - freqs[name][i, k])
                                            <= 0.5 * df)
                assert m.sum() == 1, (name, tonals[k], t, m.sum())
                assert abs(lines["cone_deg"][m][0] - cones[name][i]) < 3.0
    # nothing else: one contact per (time, line), four lines
    assert lines["time"].size == 4 * times.size
    from arrayproc.plots import plot_file
    png = tmp_path / "lines.png"
    plot_file(str(prod), str(png), "lines")  # with the truth overlay of the recording
    assert png.stat().st_size > 10_000
