"""End to end: simulated towed array → passive chain → bearings and LOFAR against truth.

Scenario (written below, simulator of issue 3): 32 hydrophones 0.75 m apart towed east at
5 kn; two moving tonal sources (760 Hz and 910 Hz) and one moving broadband source
(200-900 Hz), each at an in-band SNR of −10 dB per hydrophone at the start of the run: tonal
RMS power 10 dB below the noise in a 1 Hz band, broadband spectral level 10 dB below the noise
spectral level. Chain: data/chains/passive_e2e.toml. Checks: bearings rows follow the truth
cone angles within 0.5° RMS (broadband rows for the broadband source, line rows for the
tonal sources); the LOFAR of the beam nearest each tonal source shows its line within one
bin of the Doppler-shifted truth frequency.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from arrayproc.app.api import load_chain
from arrayproc.chain import run_chain
from arrayproc.data import data_path
from arrayproc.io.products import ProductsWriter, read_products
from arrayproc.io.recording import Recording
from arrayproc.io.truth import cone_angles, tonal_frequencies

CHAIN = data_path("chains", "passive_e2e.toml")
NL = 60.0  # noise spectral level, dB re 1 µPa²/Hz

# (name, cone angle at start (deg), range (m), course (deg), speed (kn), tonal Hz or None)
SOURCES = [("tonal_a", 75.0, 2500.0, 45.0, 6.0, 760.0),
           ("tonal_b", -105.0, 3000.0, 200.0, 5.0, 910.0),
           ("broadband", 125.0, 3500.0, 300.0, 4.0, None)]


def scenario(duration: float) -> str:
    """Scenario TOML: sources placed at a cone angle (+ starboard, − port) of the array
    heading 90°, levels set for −10 dB per hydrophone at their start range."""
    parts = [f"""
[recording]
fs = 2048.0
duration = {duration}
sound_speed = 1500.0
seed = 11

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
    for name, cone, r, course, kn, tonal in SOURCES:
        brg = math.radians(90.0 + cone)
        x, y = r * math.sin(brg), r * math.cos(brg)
        level = NL - 10.0 + 20 * math.log10(r)
        parts.append(f"""
[[source]]
name = "{name}"
start = [{x:.1f}, {y:.1f}]
depth = 50.0
course = {course}
speed_kn = {kn}
""")
        if tonal is not None:
            parts.append(f"tonals = [{{ freq = {tonal}, level_db = {level:.2f} }}]\n")
        else:
            parts.append(f"[source.broadband]\nband = [200.0, 900.0]\nlevel_db = {level:.2f}\n")
    return "".join(parts)


def run_e2e(tmp_path: Path, duration: float):
    from arrayproc.sim.run import simulate_file
    scen = tmp_path / "scen.toml"
    scen.write_text(scenario(duration))
    rec_path = tmp_path / "rec.h5"
    simulate_file(scen, rec_path)
    prod = tmp_path / "prod.h5"
    spec = load_chain(str(CHAIN))
    with Recording(rec_path) as rec, ProductsWriter(prod, source=str(rec_path),
                                                    chain=spec.text) as w:
        run_chain(rec, spec, w)
    return rec_path, read_products(prod)


def evaluate(rec_path: Path, g: dict) -> dict:
    rows = g["bearings"]
    lof = g["lofar"]
    out: dict = {}
    with Recording(rec_path) as rec:
        t = np.unique(rows["time"])
        cones = cone_angles(rec, rows["time"])
        freqs = tonal_frequencies(rec, rows["time"])
        lof_cones = cone_angles(rec, lof["time"])
        lof_freqs = tonal_frequencies(rec, lof["time"])
    broad = (rows["freq_hi"] - rows["freq_lo"]) > 10.0
    errs_all = []
    for name, *_, tonal in SOURCES:
        truth = cones[name]
        if tonal is None:
            cand = broad.copy()
        else:
            f = freqs[name][:, 0]
            df = rows["freq_hi"] - rows["freq_lo"]
            cand = (~broad) & (np.abs(0.5 * (rows["freq_lo"] + rows["freq_hi"]) - f) <= df)
        cand &= np.abs(rows["cone_deg"] - truth) < 5.0
        # one row per time: the nearest to the truth
        errs = []
        for tt in t:
            m = cand & (rows["time"] == tt)
            if m.any():
                e = rows["cone_deg"][m] - truth[m]
                errs.append(e[np.argmin(np.abs(e))])
        errs = np.asarray(errs)
        errs_all.append(errs)
        out[name] = {"detected": errs.size / t.size,
                     "rms_deg": float(np.sqrt(np.mean(errs**2))) if errs.size else np.inf,
                     "bias_deg": float(np.mean(errs)) if errs.size else np.inf}
        if tonal is not None:  # LOFAR: the line within one bin of the Doppler-shifted truth
            df = float(np.median(np.diff(lof["freq"])))
            offs = []
            for k in range(lof["time"].size):
                b = int(np.argmin(np.abs(lof["cone_deg"] - lof_cones[name][k])))
                ft = lof_freqs[name][k, 0]
                win = np.abs(lof["freq"] - ft) <= 5 * df
                spec = lof["power_db"][k, b]
                fpk = lof["freq"][win][np.argmax(spec[win])]
                offs.append((fpk - ft) / df)
            offs = np.asarray(offs)
            out[name]["lofar_bins_max"] = float(np.max(np.abs(offs)))
            out[name]["lofar_within_one_bin"] = float(np.mean(np.abs(offs) <= 1.0))
    e = np.concatenate(errs_all)
    out["rms_all_deg"] = float(np.sqrt(np.mean(e**2)))
    out["rows_per_snapshot"] = rows["time"].size / t.size  # incl. false alarms (reported only)
    return out


def check(res: dict) -> None:
    for name, *_, tonal in SOURCES:
        r = res[name]
        assert r["detected"] >= 0.9, (name, r)
        assert r["rms_deg"] < 0.5, (name, r)
        if tonal is not None:
            assert r["lofar_within_one_bin"] == 1.0, (name, r)
    assert res["rms_all_deg"] < 0.5, res


def test_towed_passive_e2e_short(tmp_path):
    rec, g = run_e2e(tmp_path, 50.0)
    res = evaluate(rec, g)
    print(res)
    check(res)


@pytest.mark.slow
def test_towed_passive_e2e_full(tmp_path):
    rec, g = run_e2e(tmp_path, 180.0)
    res = evaluate(rec, g)
    print(res)
    check(res)
