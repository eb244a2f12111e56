"""Thesis chapter 2 passive processing: the closed-form checks and the simulated end-to-end run.

Closed forms, each with the set-up of its test:

- CBF beam pattern against |I_NH|² (eq. (2.13)), θ0 = 60°, 90°, 125° (:func:`pattern_error`);
- 3 dB beamwidth over 0.886 c/(f N_H δx sin θ0) (eq. (2.41)) (:func:`beamwidth_ratio`);
- array gain, white noise against a plane wave, against 10 log10 N_H (:func:`array_gain_db`);
- KS p-values of the integrated noise against Γ(N_B) (eq. (2.24)) (:func:`gamma_ks`);
- DFT filter: passband ripple, stopband rejection, deviation of the streamed output from
  ``scipy.signal.fftconvolve`` (:func:`dft_filter_figures`).

End to end (:func:`scenario`, :func:`run_e2e`, :func:`score_e2e`): 32 hydrophones 0.75 m apart
towed east at 5 kn; two moving tonal sources (760 Hz and 910 Hz) and one moving broadband
source (200-900 Hz), each at an in-band SNR of −10 dB per hydrophone at the start of the run:
tonal RMS power 10 dB below the noise in a 1 Hz band, broadband spectral level 10 dB below the
noise spectral level; chain ``data/chains/passive_e2e.toml``. Scored: bearing rows against
the truth cone angles (broadband rows for the broadband source, line rows for the tonal
sources), and the LOFAR line of the beam nearest each tonal source against the
Doppler-shifted truth frequency.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from scipy import signal, stats

from arrayproc.chain import load_chain, run_chain
from arrayproc.chain.memory import array_blocks, run_stage
from arrayproc.data import data_path
from arrayproc.dsp.windows import time_taper
from arrayproc.io.geometry import line_array
from arrayproc.io.products import ProductsWriter, read_products
from arrayproc.io.recording import Recording
from arrayproc.io.truth import cone_angles, tonal_frequencies
from arrayproc.sim.pattern import line_array_pattern
from arrayproc.sim.plane_wave import tonal_plane_wave
from arrayproc.sim.run import simulate_file
from arrayproc.stages.beamform.cbf import CBF
from arrayproc.stages.condition.dft_filter import DFTFilter
from arrayproc.stages.passive.integrate import Integrate

__all__ = ["C", "SOURCES", "NL", "CHAIN", "run_cbf", "cbf_pattern", "pattern_error",
           "beamwidth_ratio", "array_gain_db", "gamma_ks", "dft_filter_figures",
           "dense_response", "scenario", "run_e2e", "score_e2e", "e2e"]

C = 1500.0


def run_cbf(x: np.ndarray, fs: float, positions: np.ndarray, sizes: tuple[int, ...] = (8192,),
            **kw) -> tuple[CBF, np.ndarray, list]:
    """A CBF stage with settings ``kw`` run over ``x`` cut into blocks of ``sizes``: the
    stage, its output data concatenated, and its output blocks."""
    stage = CBF(**kw)
    y, out = run_stage(stage, x, fs, positions, sizes)
    return stage, y, out


def dense_response(taps: np.ndarray, fs: float, n: int = 1 << 18
                   ) -> tuple[np.ndarray, np.ndarray]:
    """|H(f)| of centred FIR taps on a dense n-point grid (frequencies, Hz, and magnitude),
    computed from the taps alone, independently of the filter stage."""
    half = (taps.size - 1) // 2
    h = np.zeros(n, complex)
    h[np.arange(-half, half + 1) % n] = taps
    return np.fft.fftfreq(n, 1 / fs), np.abs(np.fft.fft(h))


def cbf_pattern(theta0: float) -> tuple[CBF, np.ndarray, np.ndarray]:
    """The CBF beam pattern of a plane wave from ``theta0`` (deg) and eq. (2.13), over the main
    lobe and the first sidelobe on each side (up to the second nulls, cos θ = cos θ0 ±
    2 c / (f N δx)): 32 hydrophones 0.75 m apart, a tone on a bin (its DFT is A N_DFT / 2).

    Returns
    -------
    (CBF, ndarray, ndarray)
        The stage (its ``beam_axis``, deg, and ``freqs``), the measured power |Y|² / (A N_DFT
        / 2)² and |I_NH|² on the beam axis.
    """
    fs, nfft, n_h, dx = 4096.0, 1024, 32, 0.75
    f0 = 250 * fs / nfft
    pos = line_array(n_h, dx)
    du = 2 * C / (f0 * n_h * dx)
    u0 = np.cos(np.deg2rad(theta0))
    lo = np.rad2deg(np.arccos(min(1.0, u0 + du)))
    hi = np.rad2deg(np.arccos(max(-1.0, u0 - du)))
    x = tonal_plane_wave(nfft, fs, pos, theta0, f0, amp=2.0, c=C)
    st, y, _ = run_cbf(x, fs, pos, nfft=nfft, hop=nfft, window="none", band=[f0 - 1, f0 + 1],
                       beams={"start": lo, "stop": hi, "count": 801})
    got = np.abs(y[0, 0]) ** 2 / nfft**2
    want = np.abs(line_array_pattern(st.beam_axis, theta0, f0, n_h, dx, C)) ** 2
    return st, got, want


def pattern_error(theta0: float) -> float:
    """Max |error| (dB) of the CBF beam pattern against |I_NH|² (eq. (2.13)) over the main
    lobe and first sidelobes (down to −40 dB), :func:`cbf_pattern`."""
    _, got, want = cbf_pattern(theta0)
    keep = want > want.max() * 1e-4
    return float(np.max(np.abs(10 * np.log10(got[keep] / want[keep]))))


def beamwidth_ratio(theta0: float) -> float:
    """Measured 3 dB beamwidth over 0.886 c / (f N_H δx sin θ0) (eq. (2.41)), 64 hydrophones
    0.36 m apart, at cone ``theta0`` (deg)."""
    fs, nfft, n_h, dx = 5120.0, 1024, 64, 0.36
    f0 = 200 * fs / nfft
    pos = line_array(n_h, dx)
    x = tonal_plane_wave(nfft, fs, pos, theta0, f0, c=C)
    st, y, _ = run_cbf(x, fs, pos, nfft=nfft, hop=nfft, window="none", band=[f0 - 1, f0 + 1],
                          beams={"start": theta0 - 4, "stop": theta0 + 4, "count": 1601})
    p = 10 * np.log10(np.abs(y[0, 0]) ** 2)
    p -= p.max()
    th = st.beam_axis
    k = int(np.argmax(p))
    a, b = k, k
    while p[a - 1] >= -3.0103:
        a -= 1
    while p[b + 1] >= -3.0103:
        b += 1
    left = np.interp(-3.0103, [p[a - 1], p[a]], [th[a - 1], th[a]])
    right = np.interp(-3.0103, [p[b + 1], p[b]], [th[b + 1], th[b]])
    want = 0.886 * C / (f0 * n_h * dx * np.sin(np.deg2rad(theta0)))
    return float(np.deg2rad(right - left) / want)


def array_gain_db(rng: np.random.Generator | None = None) -> float:
    """Array gain (dB) of 32 hydrophones, plane wave against white noise (expected
    10 log10 N_H), thesis 2.1.1: the SNR at the steered beam over the per-hydrophone SNR of
    the same DFTs, noise drawn from ``rng`` (default ``default_rng(12345)``)."""
    rng = np.random.default_rng(12345) if rng is None else rng
    fs, nfft, n_h, dx = 2048.0, 512, 32, 0.75
    pos = line_array(n_h, dx)
    f0 = 150 * fs / nfft
    n = nfft * 200
    noise = rng.standard_normal((n, n_h))
    sig = tonal_plane_wave(n, fs, pos, 70.0, f0, amp=0.05, c=C)
    kw = dict(nfft=nfft, hop=nfft, window="hann", band=[f0 - 40, f0 + 40],
              beams={"start": 70.0, "stop": 70.0, "count": 1})
    _, yn, _ = run_cbf(noise, fs, pos, **kw)
    st, ys, _ = run_cbf(sig, fs, pos, **kw)
    w = time_taper("hann", nfft)
    xn = np.fft.rfft(noise.reshape(-1, nfft, n_h) * w[None, :, None], axis=1)
    xs = np.fft.rfft(sig.reshape(-1, nfft, n_h) * w[None, :, None], axis=1)
    fb = np.fft.rfftfreq(nfft, 1 / fs)
    sel = (fb >= f0 - 40) & (fb <= f0 + 40)
    kf = int(np.argmin(np.abs(st.freqs - f0)))
    ks = int(np.argmin(np.abs(fb[sel] - f0)))
    snr_in = np.mean(np.abs(xs[:, sel][:, ks]) ** 2) / np.mean(np.abs(xn[:, sel]) ** 2)
    snr_out = np.mean(np.abs(ys[:, kf, 0]) ** 2) / np.mean(np.abs(yn[:, :, 0]) ** 2)
    return float(10 * np.log10(snr_out / snr_in))


def gamma_ks(n_b: int) -> float:
    """KS p-value of the beam power of white noise integrated over ``n_b`` snapshots against
    Γ(n_b) (eq. (2.24))."""
    rng = np.random.default_rng(2024 + n_b)
    fs, nfft, n_h, sigma = 1024.0, 256, 16, 0.7
    pos = line_array(n_h, 0.75)
    x = sigma * rng.standard_normal((nfft * n_b * 60, n_h))
    cbf = CBF(nfft=nfft, hop=nfft, window="none", band=[8.0, 500.0],
              beams={"start": 75.0, "stop": 75.0, "count": 1})
    blocks = array_blocks(x, fs, pos, (4096,))
    out = np.concatenate([o.data for o in Integrate(snapshots=n_b).process(cbf.process(blocks))])
    samples = out[:, :, 0].ravel() / (nfft * n_h * sigma**2)
    return float(stats.kstest(samples, stats.gamma(a=n_b).cdf).pvalue)


def dft_filter_figures() -> dict:
    """DFT filter (thesis 3.2.1.1): passband ripple and stopband rejection (dB) of two bands,
    and the streamed output's max deviation from ``scipy.signal.fftconvolve``."""
    fs = 5120.0
    out = {}
    for band, alpha in (((100.0, 2000.0), 0.1), ((0.0, 800.0), 0.2)):
        st = DFTFilter(band=list(band), taper=alpha)
        st._setup(fs)
        f, mag = dense_response(st.taps, fs)
        af = np.abs(f)
        lo, hi = band
        w = alpha * (hi - lo) / 2
        flat = (af >= (lo + w if lo > 0 else 0)) & (af <= hi - w)
        stop = (af < lo) | (af > hi)
        db = 20 * np.log10(np.maximum(mag, 1e-300))
        out[f"{lo:g}-{hi:g} Hz, alpha {alpha:g}"] = {
            "ripple_db": float(db[flat].max() - db[flat].min()),
            "rejection_db": float(-db[stop].max()), "taps": int(st.taps.size)}
    rng = np.random.default_rng(12345)
    x = rng.standard_normal((30000, 3))
    st = DFTFilter(band=[50.0, 1200.0], taper=0.1, decimate=2)
    y, _ = run_stage(st, x, fs, None, (1000, 8192, 777, 5000))
    ref = signal.fftconvolve(x, st.taps[:, None], mode="same", axes=0)[::2]
    out["stream_vs_scipy_max_rel"] = float(np.max(np.abs(y - ref)) / np.max(np.abs(ref)))
    return out


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


def run_e2e(workdir: Path, duration: float) -> tuple[Path, dict]:
    """Simulate :func:`scenario` into ``workdir``/rec.h5 and run the passive chain on it;
    the recording path and the products' groups."""
    scen = workdir / "scen.toml"
    scen.write_text(scenario(duration))
    rec_path = workdir / "rec.h5"
    simulate_file(scen, rec_path)
    prod = workdir / "prod.h5"
    spec = load_chain(str(CHAIN))
    with Recording(rec_path) as rec, ProductsWriter(prod, source=str(rec_path),
                                                    chain=spec.text) as w:
        run_chain(rec, spec, w)
    return rec_path, read_products(prod)


def score_e2e(rec_path: Path, g: dict) -> dict:
    """Bearing rows against the truth cone angles (RMS, bias, detected share per source) and
    the LOFAR line offsets of the tonal sources, in bins, from a :func:`run_e2e` output."""
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


def e2e(seconds: float, workdir: Path) -> dict:
    """:func:`run_e2e` of ``seconds`` in ``workdir``, scored by :func:`score_e2e`."""
    rec, g = run_e2e(workdir, seconds)
    return score_e2e(rec, g)
