"""Active echoes: delay 2R/c, two-way Doppler scale (c − ṙ)/(c + ṙ) (thesis eq. 4.8), level."""

from __future__ import annotations

import numpy as np
import pytest

from arrayproc.acoustics import waveforms as wf
from arrayproc.sim.run import Simulator
from arrayproc.sim.scenario import parse_scenario

C = 1500.0


def active_scenario(rdot: float, r0: float = 1500.0, waveform: str = "bpsk",
                    distortion_ms: float = 0.0) -> dict:
    act = {"waveform": waveform, "duration": 1.0, "level_db": 200.0, "interval": 100.0,
           "first": 0.5, "count": 1, "offset": [0.0, 0.0, 0.0], "direct": False, "taper": 0.05,
           "target": [{"name": "sub", "start": [0.0, r0], "depth": 50.0, "course": 0.0,
                       "speed": rdot, "ts_db": 10.0, "distortion_ms": distortion_ms}]}
    if waveform == "bpsk":
        act.update(fc=1500.0, bits=255)
    else:
        act.update(f0=1300.0, f1=1700.0)
    if rdot < 0:
        act["target"][0].update(course=180.0, speed=-rdot)
    return {
        "recording": {"fs": 5120.0, "duration": 0.5 + 2 * r0 / (C - abs(rdot)) + 1.6,
                      "sound_speed": C, "seed": 1},
        "array": {"type": "line", "n": 1, "spacing": 1.0, "depth": 50.0},
        "ownship": {"start": [0.0, 0.0], "heading": 0.0},
        "active": act,
    }


def matched_filter_estimate(x: np.ndarray, w: wf.Waveform, fs: float, scales: np.ndarray):
    """(best scale, arrival time of the pulse start) by a wideband matched filter over scales,
    each refined by a parabola."""
    chi = wf.wideband_ambiguity(x, w, fs, scales)
    peak = chi.max(axis=1)
    i = int(np.argmax(peak))
    a, b, c = peak[i - 1: i + 2]
    ds = scales[1] - scales[0]
    d = scales[i] + 0.5 * (a - c) / (a - 2 * b + c) * ds
    row = chi[i]
    k = int(np.argmax(row))
    a, b, c = row[k - 1: k + 2]
    return d, (k + 0.5 * (a - c) / (a - 2 * b + c)) / fs


@pytest.mark.parametrize("rdot", [10.0, -7.0])
def test_echo_delay_and_doppler_scale(rdot):
    r0 = 1500.0
    d = active_scenario(rdot, r0)
    sim = Simulator(parse_scenario(d, "active.toml"))
    x = sim.render(0, sim.n_samples)[:, 0].astype(float)
    w = sim.active.spec.waveform
    tp = 0.5
    t_s = (r0 + C * tp) / (C - rdot)  # the pulse meets the target
    R = C * (t_s - tp)
    d_true = (C - rdot) / (C + rdot)
    scales = d_true + np.linspace(-2e-3, 2e-3, 81)
    d_est, t_arr = matched_filter_estimate(x, w, sim.fs, scales)
    delay = t_arr - tp
    print(f"echo rdot={rdot:+.1f}: delay {delay:.6f} s vs 2R/c {2 * R / C:.6f} s "
          f"(err {(delay - 2 * R / C) * sim.fs:+.3f} samples, tol 1); scale {d_est:.7f} vs "
          f"(c-rdot)/(c+rdot) {d_true:.7f} (err {d_est - d_true:+.2e}, "
          f"= {wf.range_rate_from_scale(d_est, C) - rdot:+.4f} m/s)")
    assert abs(delay - 2 * R / C) * sim.fs <= 1.0
    assert abs(d_est - d_true) < 1e-4
    # truth rows agree with the closed form
    truth, _ = sim.truth()
    e = truth["echoes"]
    assert abs(e["delay_s"][0] - 2 * R / C) < 1e-9
    assert abs(e["range_rate_mps"][0] - rdot) < 1e-9
    # echo level (RMS of the carrier over the untapered middle) vs SL + TS − 40 log10 R
    mid = slice(int((t_arr + 0.2) * sim.fs), int((t_arr + 0.6) * sim.fs))
    lvl = 20 * np.log10(np.sqrt(np.mean(x[mid] ** 2)) / 1e-6)
    print(f"echo level {lvl:.3f} dB vs truth {e['level_db'][0]:.3f} dB")
    assert abs(lvl - e["level_db"][0]) < 0.2


def test_hfm_echo_and_distortion_spread():
    """HFM echo arrives at 2R/c; eq. (4.6) distortion lowers the BPSK matched-filter peak."""
    r0, rdot = 1200.0, 0.0
    sim = Simulator(parse_scenario(active_scenario(rdot, r0, "hfm"), "a.toml"))
    x = sim.render(0, sim.n_samples)[:, 0].astype(float)
    # HFM is Doppler tolerant (delay and scale couple): match at the true scale 1
    row = wf.wideband_ambiguity(x, sim.active.spec.waveform, sim.fs, [1.0])[0]
    k = int(np.argmax(row))
    a, b, c = row[k - 1: k + 2]
    t_arr = (k + 0.5 * (a - c) / (a - 2 * b + c)) / sim.fs
    print(f"HFM echo delay error {(t_arr - 0.5 - 2 * r0 / C) * sim.fs:+.3f} samples")
    assert abs(t_arr - 0.5 - 2 * r0 / C) * sim.fs <= 1.0
    peaks = []
    for alpha in (0.0, 1.0):
        sim = Simulator(parse_scenario(active_scenario(rdot, r0, "bpsk", alpha), "a.toml"))
        x = sim.render(0, sim.n_samples)[:, 0].astype(float)
        chi = wf.wideband_ambiguity(x, sim.active.spec.waveform, sim.fs,
                                    1 + np.linspace(-3e-3, 3e-3, 61))
        peaks.append(chi.max())
    loss = 20 * np.log10(peaks[0] / peaks[1])
    print(f"BPSK loss from a 1 ms eq. (4.6) distortion: {loss:.2f} dB")
    assert loss > 1.0
