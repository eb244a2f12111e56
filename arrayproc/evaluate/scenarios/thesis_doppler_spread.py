"""Thesis fig. 4.4: matched-filter loss of BPSK and HFM echoes under the time distortion of
eq. (4.6), p(t) ↦ p(t + α sin(2πt/T)(1 − cos 2πt/T)), for α = 0 … 1 ms.

The pulses are the thesis' (4 s, 2047-bit BPSK at 1500 Hz; an HFM of the same duration and
bandwidth). Two ways of distorting them: directly (the thesis' procedure: the pulse evaluated
on the distorted time axis) and through the simulator (an echo from a static target 1.5 km
away with ``distortion_ms = α``, so the kernel applies eq. (4.6)). Both are matched by the
``matched_filter`` stage's own bank (:mod:`arrayproc.stages.active.bank`): the BPSK over
range rates ±1.2 m/s in 0.02 m/s steps (eq. (4.7), Doppler sensitive), the HFM with its one
replica (Doppler insensitive). Loss
= peak without distortion / peak with, in dB.

Thesis: the BPSK loses up to about 6 dB at α = 1 ms, the HFM at most about 3 dB. The loss is
given as 20 log10 of the peak ratio (the peak of |χ|, an amplitude) and, for
comparison, 10 log10 of it.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from arrayproc.acoustics import waveforms as wf
from arrayproc.sim.run import Simulator
from arrayproc.sim.scenario import parse_scenario
from arrayproc.stages.active import bank as bk

__all__ = ["FS", "C", "R0", "pulses", "peak", "direct", "simulated", "fig_4_4"]

FS = 5120.0
C = 1500.0
R0 = 1500.0


def pulses() -> dict[str, wf.Waveform]:
    b = wf.bpsk(1500.0, 4.0, 2047)
    half = b.bandwidth / 2
    return {"bpsk": b, "hfm": wf.hfm(1500.0 - half, 1500.0 + half, 4.0)}


def peak(x: np.ndarray, w: wf.Waveform, kind: str) -> float:
    """Peak |chi| of the ``matched_filter`` stage's bank (arrayproc.stages.active.bank: the
    replicas p(d t) by chirp-z spectra, FFT correlation)."""
    if kind == "bpsk":
        rates = np.arange(-1.2, 1.2001, 0.02)  # |d - 1| <= 1.6e-3, 0.02 m/s steps
    else:
        rates = np.zeros(1)  # Doppler insensitive: one replica, as the stage does
    # the band 0 ... 0.45 fs: lags sampled at about 2300 Hz, so that the peak of a spread
    # (distorted) correlation is not missed between lag samples (the stage's default band
    # samples the BPSK's lags at about 1100 Hz, the HFM's at 560 Hz)
    band = (0.0, 0.45 * FS)
    plan = bk.band_plan(FS, x.size, band)
    X = np.fft.rfft(x, plan.n_fft)[plan.k0:plan.k0 + plan.n_bins].astype(np.complex64)
    bank = bk.replica_spectra(w.sample(FS), FS, plan.f0, plan.df, plan.n_bins,
                              bk.doppler_scale(rates, C))
    out = np.empty((rates.size, plan.n_bins), np.float32)
    bk.correlate(X, bank, out)
    return float(np.sqrt(out.max()))


def direct(w: wf.Waveform, alpha: float) -> np.ndarray:
    """The distorted pulse with 0.25 s of silence before it (the best lag may be negative)."""
    t = np.arange(int((w.duration + 0.75) * FS)) / FS - 0.25
    x = w(wf.time_distortion(t, alpha, w.duration))
    return np.where((t >= 0) & (t <= w.duration), x, 0.0)


def simulated(kind: str, alpha: float) -> np.ndarray:
    act = {"waveform": kind, "duration": 4.0, "level_db": 200.0, "interval": 100.0,
           "first": 0.0, "count": 1, "direct": False, "taper": 0.0,
           "target": [{"start": [0.0, R0], "depth": 50.0, "heading": 0.0, "ts_db": 0.0,
                       "distortion_ms": alpha * 1e3}]}
    if kind == "bpsk":
        act.update(fc=1500.0, bits=2047)
    else:
        w = pulses()["hfm"]
        act.update(f0=w.f0, f1=w.f1)
    d = {"recording": {"fs": FS, "duration": 2 * R0 / C + 4.5, "sound_speed": C},
         "array": {"type": "line", "n": 1, "spacing": 1.0, "depth": 50.0},
         "active": act}
    sim = Simulator(parse_scenario(d, "doppler_spread"))
    return sim.render(0, sim.n_samples)[:, 0].astype(float)


def fig_4_4(alphas: list[float], log: Callable[[dict], None] | None = None) -> list[dict]:
    """Matched-filter loss (dB, 20 log10 and 10 log10 of the peak ratio) of both pulses,
    distorted directly and through the simulator, for each distortion amplitude α (s);
    ``log(row)`` after each α.

    Returns
    -------
    list of dict
        One row per α: ``alpha_ms`` and ``{bpsk,hfm}_{direct,sim}_loss_{db,10log}``.
    """
    ws = pulses()
    rows = []
    ref = {}
    for a in alphas:
        row = {"alpha_ms": a * 1e3}
        for kind, w in ws.items():
            for how, x in (("direct", direct(w, a)), ("sim", simulated(kind, a))):
                p = peak(x, w, kind)
                key = f"{kind}_{how}"
                ref.setdefault(key, p if a == 0 else None)
                if ref[key] is None:
                    ref[key] = peak(direct(w, 0.0) if how == "direct" else simulated(kind, 0.0),
                                    w, kind)
                row[f"{key}_loss_db"] = 20 * np.log10(ref[key] / p)
                row[f"{key}_loss_10log"] = 10 * np.log10(ref[key] / p)
        rows.append(row)
        if log is not None:
            log(row)
    return rows
