"""End to end: a simulated towed array with two sources whose cone angles cross, each with its
own tonal → the shipped ``towed_passive`` chain (``lines`` and ``bearings``) → the shipped
``multi_target`` tracker (``measurements = "lines+bearings"``) → two confirmed tracks, each
following its own source through the crossing.

Scenario (below): 32 hydrophones 0.75 m apart towed east at 5 kn, 72 s; two sources on the
starboard side 1 km away, "alpha" (cone 52°, going west at 6 kn: its cone grows 0.25°/s) and
"bravo" (cone 66°, going east at 10 kn: its cone shrinks 0.14°/s), crossing at t ≈ 36 s;
each tonal 10 dB above the noise in a 1 Hz band per hydrophone at 1 km (over the TPSW
background raised by the source's own broadband), a broadband band 10 dB under the noise
spectrum per hydrophone.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from arrayproc.chain import run_chain
from arrayproc.data import data_path
from arrayproc.io.products import ProductsWriter, read_products
from arrayproc.io.recording import Recording
from arrayproc.io.truth import cone_angles
from arrayproc.stages import load_chain
from arrayproc.track.runner import run_tracker

CHAIN = data_path("chains", "towed_passive.toml")
TRACKER = data_path("trackers", "multi_target.toml")
NL = 60.0  # noise spectral level, dB re 1 µPa²/Hz
R = 1000.0
# (name, cone at start (deg, starboard), course (deg), speed (kn), tonal Hz)
SOURCES = [("alpha", 52.0, 270.0, 6.0, 310.0), ("bravo", 66.0, 90.0, 10.0, 530.0)]


def scenario(duration: float) -> str:
    parts = [f"""
[recording]
fs = 2048.0
duration = {duration}
sound_speed = 1500.0
seed = 9

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
    for name, cone, course, kn, f in SOURCES:
        brg = math.radians(90.0 + cone)
        x, y = R * math.sin(brg), R * math.cos(brg)
        level = NL + 10.0 + 20 * math.log10(R)
        parts.append(f"""
[[source]]
name = "{name}"
start = [{x:.1f}, {y:.1f}]
depth = 50.0
course = {course}
speed_kn = {kn}
tonals = [{{ freq = {f}, level_db = {level:.2f} }}]
[source.broadband]
band = [100.0, 900.0]
level_db = {NL - 10.0 + 20 * math.log10(R):.2f}
""")
    return "".join(parts)


def test_crossing_sources_stay_two_tracks_from_a_recording(tmp_path: Path):
    from arrayproc.sim.run import simulate_file
    scen = tmp_path / "scen.toml"
    scen.write_text(scenario(72.0))
    rec = tmp_path / "rec.h5"
    simulate_file(scen, rec)
    prod = tmp_path / "prod.h5"
    spec = load_chain(str(CHAIN))
    with Recording(rec) as r, ProductsWriter(prod, source=str(rec), chain=spec.text) as w:
        run_chain(r, spec, w)
    out = tmp_path / "tracks.h5"
    run_tracker(str(prod), str(TRACKER), str(out))
    g = read_products(str(out))["tracks"]
    assert "meas_freq_hz" in g and "f_hz" in g  # the lines+bearings path ran
    tid, st, t = np.asarray(g["track_id"]), np.asarray(g["status"]), np.asarray(g["time"])
    with Recording(str(rec), require_geometry=False) as r:
        truth = cone_angles(r, np.unique(t))
    ut = np.unique(t)
    held = {}
    for i in np.unique(tid[st == 1]):
        s = (tid == i) & (st == 1)
        fz = np.asarray(g["meas_freq_hz"])[s]
        fz = fz[np.isfinite(fz)]
        if fz.size < 15:
            continue
        # the track's lines are one source's tonal (Doppler within ±3 Hz)
        owner = [n for n, _c, _k, _s, f in SOURCES if np.all(np.abs(fz - f) < 3.0)]
        assert len(owner) == 1, (i, np.unique(np.round(fz)))
        cone = np.asarray(g["cone_deg"])[s]
        ti = np.searchsorted(ut, t[s])
        err = np.abs(cone - truth[owner[0]][ti])
        assert np.median(err) < 2.0 and err[-5:].max() < 4.0, (owner, err)
        held.setdefault(owner[0], []).append((t[s].min(), t[s].max()))
    assert sorted(held) == ["alpha", "bravo"], held
    for spans in held.values():  # one track through the crossing (t ≈ 36 s)
        assert len(spans) == 1 and spans[0][0] < 20.0 and spans[0][1] > 60.0, spans
