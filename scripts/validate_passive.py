"""Passive chain (issue 4) against the thesis closed forms: the numbers of docs/validation.md.

Measures, with the same set-ups as the tests (tests/test_cbf.py, test_integrate.py,
test_dft_filter.py, test_passive_e2e.py):

- CBF beam pattern vs |I_NH|² (eq. 2.13): max |error| in dB over the main lobe and first
  sidelobes (down to −40 dB), θ0 = 60°, 90°, 125°;
- 3 dB beamwidth / 0.886 c/(f N_H δx sin θ0) (eq. 2.41) at θ0 = 90° and 60°;
- array gain (white noise vs plane wave) in dB vs 10 log10 N_H;
- KS p-values of the integrated noise against Γ(N_B) (eq. 2.24);
- DFT filter: passband ripple, stopband rejection, max deviation from scipy.signal.fftconvolve
  of the streamed output;
- end to end (``--e2e SECONDS``, default 50): bearing RMS errors and LOFAR line offsets.

    .venv/bin/python scripts/validate_passive.py [--e2e 180] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from arrayproc.chain.domains import Domain, TimeMeta  # noqa: E402
from tests.stages import test_passive_e2e as te  # noqa: E402
from tests.stages.beamform import test_cbf as tc  # noqa: E402  (exact plane-wave synthesis)
from tests.stages.condition import test_dft_filter as td  # noqa: E402


def pattern_error(theta0: float) -> float:
    fs, nfft, n_h, dx = 4096.0, 1024, 32, 0.75
    f0 = 250 * fs / nfft
    pos = tc.line_array(n_h, dx)
    du = 2 * tc.C / (f0 * n_h * dx)
    u0 = np.cos(np.deg2rad(theta0))
    lo = np.rad2deg(np.arccos(min(1.0, u0 + du)))
    hi = np.rad2deg(np.arccos(max(-1.0, u0 - du)))
    x = tc.plane_wave(nfft, fs, pos, theta0, f0, amp=2.0)
    st, y, _ = tc.run_cbf(x, fs, pos, nfft=nfft, hop=nfft, window="none", band=[f0 - 1, f0 + 1],
                          beams={"start": lo, "stop": hi, "count": 801})
    got = np.abs(y[0, 0]) ** 2 / nfft**2
    want = np.abs(tc.i_nh(st.beam_axis, theta0, f0, n_h, dx)) ** 2
    keep = want > want.max() * 1e-4
    return float(np.max(np.abs(10 * np.log10(got[keep] / want[keep]))))


def beamwidth_ratio(theta0: float) -> float:
    fs, nfft, n_h, dx = 5120.0, 1024, 64, 0.36
    f0 = 200 * fs / nfft
    pos = tc.line_array(n_h, dx)
    x = tc.plane_wave(nfft, fs, pos, theta0, f0)
    st, y, _ = tc.run_cbf(x, fs, pos, nfft=nfft, hop=nfft, window="none", band=[f0 - 1, f0 + 1],
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
    want = 0.886 * tc.C / (f0 * n_h * dx * np.sin(np.deg2rad(theta0)))
    return float(np.deg2rad(right - left) / want)


def array_gain_db() -> float:
    rng = np.random.default_rng(12345)
    fs, nfft, n_h, dx = 2048.0, 512, 32, 0.75
    pos = tc.line_array(n_h, dx)
    f0 = 150 * fs / nfft
    n = nfft * 200
    noise = rng.standard_normal((n, n_h))
    sig = tc.plane_wave(n, fs, pos, 70.0, f0, amp=0.05)
    kw = dict(nfft=nfft, hop=nfft, window="hann", band=[f0 - 40, f0 + 40],
              beams={"start": 70.0, "stop": 70.0, "count": 1})
    _, yn, _ = tc.run_cbf(noise, fs, pos, **kw)
    st, ys, _ = tc.run_cbf(sig, fs, pos, **kw)
    w = tc.time_window("hann", nfft)
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
    from scipy import stats

    from arrayproc.chain.block import Block
    from arrayproc.stages.beamform.cbf import CBF
    from arrayproc.stages.passive.integrate import Integrate
    rng = np.random.default_rng(2024 + n_b)
    fs, nfft, n_h, sigma = 1024.0, 256, 16, 0.7
    pos = tc.line_array(n_h, 0.75)
    x = sigma * rng.standard_normal((nfft * n_b * 60, n_h))
    cbf = CBF(nfft=nfft, hop=nfft, window="none", band=[8.0, 500.0],
              beams={"start": 75.0, "stop": 75.0, "count": 1})
    blocks = (Block(x[i:i + 4096].astype(np.float32), Domain.TIME, i / fs, 4096 / fs,
                    fs, pos, None, meta=TimeMeta(i, 4096))
              for i in range(0, x.shape[0], 4096))
    out = np.concatenate([o.data for o in Integrate(snapshots=n_b).process(cbf.process(blocks))])
    samples = out[:, :, 0].ravel() / (nfft * n_h * sigma**2)
    return float(stats.kstest(samples, stats.gamma(a=n_b).cdf).pvalue)


def dft_filter_figures() -> dict:
    from scipy import signal

    from arrayproc.stages.condition.dft_filter import DFTFilter
    fs = 5120.0
    out = {}
    for band, alpha in (((100.0, 2000.0), 0.1), ((0.0, 800.0), 0.2)):
        st = DFTFilter(band=list(band), taper=alpha)
        st._setup(fs)
        f, mag = td.dense_response(st.taps, fs)
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
    y, _ = td.run(st, x, fs, sizes=(1000, 8192, 777, 5000))
    ref = signal.fftconvolve(x, st.taps[:, None], mode="same", axes=0)[::2]
    out["stream_vs_scipy_max_rel"] = float(np.max(np.abs(y - ref)) / np.max(np.abs(ref)))
    return out


def e2e(seconds: float) -> dict:
    with tempfile.TemporaryDirectory() as d:
        rec, g = te.run_e2e(Path(d), seconds)
        return te.evaluate(rec, g)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--e2e", type=float, default=50.0, help="simulated seconds (0: skip)")
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    res = {
        "pattern_max_err_db": {f"{t:g}": pattern_error(t) for t in (60.0, 90.0, 125.0)},
        "beamwidth_ratio": {f"{t:g}": beamwidth_ratio(t) for t in (90.0, 60.0)},
        "array_gain_db": array_gain_db(), "array_gain_expected_db": 10 * np.log10(32),
        "gamma_ks_pvalue": {str(n): gamma_ks(n) for n in (1, 4, 10)},
        "dft_filter": dft_filter_figures(),
    }
    if args.e2e > 0:
        res["e2e"] = {"seconds": args.e2e, **e2e(args.e2e)}
    print(json.dumps(res, indent=2))
    if args.json:
        Path(args.json).write_text(json.dumps(res, indent=2))


if __name__ == "__main__":
    main()
