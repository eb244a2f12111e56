"""Benchmark: the K strongest correlation peaks of every hydrophone pair (several sources).

The six-hydrophone frame (1.7 m, 15 pairs) at 32 kHz, 4096-sample snapshots, band 200-4000 Hz,
two simultaneous broadband sources in noise (:func:`arrayproc.evaluate.multi_source.
burst_frames`), K = 3. Timed in one process, alternating in each repeat:

* ``ours``: :class:`arrayproc.stages.delay.peaks.PairPeakEstimator` on batches of snapshots
  (one batch of FFTs, the band's cross-spectra of all pairs, one batch of inverse FFTs, the
  windowed peak search, band-limited Newton refinement of every candidate, distinct peaks, σ
  and ρ, in numba kernels);
* ``plain``: what a careful user writes with scipy, per snapshot and pair:
  ``scipy.signal.correlate`` (FFT method) of the band-passed channels,
  ``scipy.signal.find_peaks`` inside the lag window with ``distance`` = 1/B, the K highest,
  a parabolic sub-sample fit.

CPU seconds of the process (``time.process_time``), ours on one numba thread; reports
snapshots per CPU second, the ratio, and the median and largest lag difference between the two
on the peaks they share (within 2 samples; the plain fit is parabolic on a band-passed
correlation, so they differ by its bias, largest on weak peaks beside a strong one).

    python scripts/bench_tde_peaks.py [--snapshots 64] [--repeats 3] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import time

import numba
import numpy as np
import scipy.signal as ss

from arrayproc.evaluate.multi_source import CASES, burst_frames
from arrayproc.stages.delay.peaks import PairPeakEstimator, all_pairs


def frames(n_snap: int, seed: int) -> tuple[np.ndarray, object]:
    case = CASES["frame"]()
    x = np.stack([burst_frames(np.random.default_rng(seed + i), case)[0] for i in range(n_snap)])
    return x, case


def plain(x: np.ndarray, case, pairs: np.ndarray, lag: np.ndarray, k: int) -> np.ndarray:
    fs = case.fs
    sos = ss.butter(8, case.band, "bandpass", fs=fs, output="sos")
    sep = max(1, int(fs / (case.band[1] - case.band[0])))
    out = np.full((x.shape[0], pairs.shape[0], k), np.nan)
    n = x.shape[1]
    lags = ss.correlation_lags(n, n, "full")
    for s in range(x.shape[0]):
        y = ss.sosfiltfilt(sos, x[s], axis=0)
        for p, (a, b) in enumerate(pairs):
            r = ss.correlate(y[:, b], y[:, a], "full", "fft")
            L = int(np.ceil(lag[p] * fs))
            w = (lags >= -L) & (lags <= L)
            rw, lw = r[w], lags[w]
            pk, _ = ss.find_peaks(rw, distance=sep)
            pk = pk[np.argsort(rw[pk])[::-1][:k]]
            for q, i in enumerate(pk):
                if 0 < i < rw.size - 1:
                    y0, y1, y2 = rw[i - 1], rw[i], rw[i + 1]
                    d = 0.5 * (y0 - y2) / (y0 - 2 * y1 + y2)
                else:
                    d = 0.0
                out[s, p, q] = (lw[i] + d) / fs
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--snapshots", type=int, default=64)
    ap.add_argument("--batch", type=int, default=16)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json")
    a = ap.parse_args(argv)
    numba.set_num_threads(1)
    x, case = frames(a.snapshots, a.seed)
    el = case.elements
    pairs = all_pairs(el.shape[0])
    lag = np.linalg.norm(el[pairs[:, 0]] - el[pairs[:, 1]], axis=1) / case.c + 1e-4
    est = PairPeakEstimator(case.n, case.fs, lag, pairs, el.shape[0], case.band, 3, "none")
    est(x[:a.batch])  # compile
    t_ours, t_plain = [], []
    for _ in range(a.repeats):
        t0 = time.process_time()
        got = np.concatenate([est(x[i:i + a.batch]).tau for i in range(0, len(x), a.batch)])
        t_ours.append(time.process_time() - t0)
        t0 = time.process_time()
        ref = plain(x, case, pairs, lag, 3)
        t_plain.append(time.process_time() - t0)
    diff = []
    for s in range(len(x)):
        for p in range(len(pairs)):
            for v in got[s, p][np.isfinite(got[s, p])]:
                r = ref[s, p][np.isfinite(ref[s, p])]
                if r.size and np.min(np.abs(r - v)) < 2 / case.fs:
                    diff.append(np.min(np.abs(r - v)))
    res = {"snapshots": len(x), "pairs": int(len(pairs)), "k": 3,
           "ours_snapshots_per_cpu_s": len(x) / min(t_ours),
           "plain_snapshots_per_cpu_s": len(x) / min(t_plain),
           "ratio_best": min(t_plain) / min(t_ours),
           "ratio_each": [p / o for o, p in zip(t_ours, t_plain, strict=True)],
           "real_time_ours": len(x) * case.n / case.fs / min(t_ours),
           "shared_peaks": len(diff),
           "largest_lag_difference_s": float(max(diff)) if diff else None,
           "median_lag_difference_s": float(np.median(diff)) if diff else None}
    print(json.dumps(res, indent=1))
    if a.json:
        with open(a.json, "w") as f:
            json.dump(res, f, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
