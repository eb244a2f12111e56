"""Benchmark: per-snapshot delays of 64 channels (docs/performance/delays.md).

64 hydrophones 0.36 m apart (the thesis's towed array, app. C) sampled at 5120 Hz, 1 s snapshots
with 50 % overlap, band 100-2000 Hz, every channel against channel 0 with the lag limited to the
physically possible ±|p_i − p_0|/c. Timed in one process:

* ``ours``: :class:`arrayproc.stages.delay.gcc.GccEstimator` on batches of snapshots (one batch
  of FFTs of all channels, cross-spectrum over the band's bins only, one batch of inverse FFTs,
  peak search inside the lag window, band-limited sub-sample refinement, σ and ρ);
* ``plain``: what a careful user writes with scipy: per snapshot and channel pair
  ``scipy.signal.correlate`` (FFT method) + ``scipy.signal.correlation_lags``, argmax inside
  the same lag window and a parabolic sub-sample fit.

Times are CPU seconds of the process (``time.process_time``: the machine is shared, wall
time is not ours), ours on ``--threads`` numba threads (default 1, like the plain loop).
The two alternate in each repeat (so they see the same load); reports multiples of real time
(seconds of data per CPU second, best repeat), the ratio of the best times and of each
repeat, the largest difference between the two delay estimates, and the peak traced memory of
``ours`` streaming files of two lengths (flat in file length: the stream holds one batch of
snapshots).

    python scripts/bench_tde.py [--seconds 60] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import time
import tracemalloc

import numba
import numpy as np
import scipy.signal as ss

from arrayproc.stages.delay.gcc import GccEstimator

FS, NCH, SPACING, C = 5120.0, 64, 0.36, 1500.0
NFFT, HOP, BAND = 5120, 2560, (100.0, 2000.0)


def stream(seconds: float, seed: int, block: int = HOP):
    """Blocks (block, 64) float32 of a plane wave at cone 60° (integer-sample delays) in noise."""
    rng = np.random.default_rng(seed)
    delays = np.round(np.arange(NCH) * SPACING * np.cos(np.radians(60)) / C * FS).astype(int)
    dmax = int(delays.max())
    hist = rng.standard_normal(dmax)
    n_blocks = int(seconds * FS) // block
    for _ in range(n_blocks):
        src = np.concatenate([hist, rng.standard_normal(block)])
        idx = dmax + np.arange(block)[:, None] - delays[None, :]
        x = 0.5 * src[idx] + rng.standard_normal((block, NCH))
        hist = src[-dmax:]
        yield x.astype(np.float32)


def snapshots(blocks, batch: int):
    """Batches (S, NFFT, NCH) of 50 %-overlapping snapshots from a block stream."""
    buf = np.zeros((0, NCH), np.float32)
    out = []
    for b in blocks:
        buf = np.concatenate([buf, b])
        while buf.shape[0] >= NFFT:
            out.append(buf[:NFFT])
            buf = buf[HOP:]
            if len(out) == batch:
                yield np.stack(out)
                out = []
    if out:
        yield np.stack(out)


def max_lags() -> np.ndarray:
    return np.arange(NCH) * SPACING / C + 1.0 / FS


def run_ours(seconds: float, batch: int, seed: int, interp: str) -> tuple[float, int,
                                                                         np.ndarray]:
    est = GccEstimator(NFFT, FS, NCH, 0, BAND, max_lags(), "none", interp)
    gen = list(snapshots(stream(seconds, seed), batch))
    est(gen[0])  # compile and plan
    t0 = time.process_time()
    taus = [est(fr).tau for fr in gen]
    dt = time.process_time() - t0
    tau = np.concatenate(taus)
    return dt, tau.shape[0], tau


def run_plain(frames: np.ndarray) -> tuple[float, np.ndarray]:
    lim = np.ceil(max_lags() * FS).astype(int)
    lags = ss.correlation_lags(NFFT, NFFT, mode="full")
    out = np.zeros((frames.shape[0], NCH))
    t0 = time.process_time()
    for s, x in enumerate(frames):
        for i in range(1, NCH):
            r = ss.correlate(x[:, i], x[:, 0], mode="full", method="fft")
            lags = ss.correlation_lags(NFFT, NFFT, mode="full")
            w = np.flatnonzero(np.abs(lags) <= lim[i])
            k = w[np.argmax(r[w])]
            d = 0.0
            if w[0] < k < w[-1]:
                y0, y1, y2 = r[k - 1], r[k], r[k + 1]
                den = y0 - 2 * y1 + y2
                d = 0.5 * (y0 - y2) / den if den < 0 else 0.0
            out[s, i] = (lags[k] + d) / FS
    return time.process_time() - t0, out


def peak_memory(seconds: float, batch: int, seed: int, interp: str) -> float:
    est = GccEstimator(NFFT, FS, NCH, 0, BAND, max_lags(), "none", interp)
    tracemalloc.start()
    for fr in snapshots(stream(seconds, seed), batch):
        est(fr)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return peak / 2**20


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=60.0, help="data length for ours, s")
    ap.add_argument("--plain-snapshots", type=int, default=12)
    ap.add_argument("--batch", type=int, default=8, help="snapshots per estimator call")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--interp", choices=("fft", "sinc", "parabolic"), default="fft",
                    help="sub-sample refinement of ours")
    ap.add_argument("--threads", type=int, default=1, help="numba threads of ours (the plain "
                    "loop runs on one)")
    ap.add_argument("--json")
    a = ap.parse_args(argv)
    numba.set_num_threads(a.threads)
    frames = next(snapshots(stream(a.plain_snapshots * HOP / FS + 1.0, a.seed),
                            a.plain_snapshots))
    # ours and the plain loop alternate, so both see the same load; ratio per repeat
    ours, plain = [], []
    for _ in range(a.repeats):
        dt, n_snap, tau = run_ours(a.seconds, a.batch, a.seed, a.interp)
        ours.append(dt / n_snap)
        dtp, tau_p = run_plain(frames)
        plain.append(dtp / frames.shape[0])
    ratios = [p / o for o, p in zip(ours, plain)]
    est = GccEstimator(NFFT, FS, NCH, 0, BAND, max_lags(), "none", a.interp)
    tau_o = est(frames).tau
    per_snap, per_snap_plain = min(ours), min(plain)
    data_per_snap = HOP / FS  # each new snapshot brings HOP samples of data
    res = {
        "interp": a.interp, "numba_threads": a.threads, "channels": NCH, "fs_hz": FS,
        "nfft": NFFT, "hop": HOP, "band_hz": list(BAND),
        "snapshots_ours": n_snap, "snapshots_plain": int(frames.shape[0]),
        "ms_per_snapshot_ours": [1e3 * v for v in ours],
        "ms_per_snapshot_plain": [1e3 * v for v in plain],
        "x_real_time_ours": data_per_snap / per_snap,
        "x_real_time_plain": data_per_snap / per_snap_plain,
        "speedup_vs_plain": per_snap_plain / per_snap,
        "speedup_per_repeat": ratios,
        "speedup_median": float(np.median(ratios)),
        "max_abs_diff_vs_plain_samples": float(np.max(np.abs(tau_o - tau_p)) * FS),
        "peak_mem_mib": {f"{s:g} s": peak_memory(s, a.batch, a.seed, a.interp)
                         for s in (a.seconds / 2, a.seconds * 2)},
    }
    print(json.dumps(res, indent=1))
    if a.json:
        with open(a.json, "w") as f:
            json.dump(res, f, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
