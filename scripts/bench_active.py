"""Bench of the active chain on one ping of the thesis's configuration (thesis 4.1.3.1).

48 hydrophones at 5120 Hz, a 4 s 2047-bit BPSK at 1500 Hz, a 30 s receive window (+ the
pulse), 360 beams, a bank of range-rate channels (default the thesis's 61: -15 ... 15 m/s in
0.5 m/s steps; ``--step 0`` for the stage's default 3 dB-resolution grid), CA-CFAR and
contacts: the stages ``active_beams`` -> ``matched_filter`` -> ``cfar`` run end to end on an
in-memory recording (white noise plus one echo), timed with wall clock and CPU time, peak
resident memory reported against the size the whole cube would take.

Then, in the same process, the matched filter alone on ``--ref-beams`` beams against the plain
implementation a careful user would write: ``scipy.signal.fftconvolve`` of each beam's
baseband series with each time-reversed conjugate baseband replica (mode "valid"), then
|.|^2; the ratio is reference time / our time for the same cells.

    .venv/bin/python scripts/bench_active.py [--beams 360] [--step 0.5] [--threads 2]
        [--ref-beams 4] [--steps] [--json OUT]

``--step 0`` is the shipped chain's range-rate grid (the 3 dB Doppler resolution: 271
channels); ``--steps`` prints each step's share of the ping's CPU time.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import sys
import time
from types import SimpleNamespace

import numpy as np

from arrayproc.chain.reader import read_blocks


def rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


class MemRecording:
    """A recording held in memory with the reader's interface used by the active stages."""

    def __init__(self, x: np.ndarray, fs: float, positions: np.ndarray, act) -> None:
        from arrayproc.chain import Pose
        self.x, self.fs, self.positions, self._act = x, fs, positions, act
        self.n_samples = x.shape[0]
        self.sound_speed = 1500.0
        self.path = "<memory>"
        self._pose = Pose(np.zeros(2), 180.0, 80.0, 0.0, positions)  # still: the echo too

    def active(self):
        return self._act

    def pose(self, t: float):
        return self._pose

    @property
    def n_channels_file(self) -> int:
        return self.x.shape[1]

    n_channels = n_channels_file

    def read(self, start: int, stop: int, dtype=np.float32) -> np.ndarray:
        return np.asarray(self.x[start:stop], dtype)

    def poses(self, t: np.ndarray) -> list:
        return [self._pose] * len(t)


def instrument() -> dict:
    """Wrap the steps of a ping with timers (thread CPU time and wall time, summed over the
    threads that run them); returns the dict they fill: name -> [cpu s, wall s, calls]."""
    import threading

    from arrayproc.dsp import fft as F
    from arrayproc.stages.active import _kernels as AK
    from arrayproc.stages.active import bank as bk
    from arrayproc.stages.active import detect as dt
    from arrayproc.stages.active import matched_filter as mfm
    from arrayproc.stages.active import ping_beams as pb
    acc: dict = {}
    lock = threading.Lock()

    def wrap(obj, name: str, label: str) -> None:
        f = getattr(obj, name)

        def timed(*a, **k):
            t, w = time.thread_time(), time.perf_counter()
            try:
                return f(*a, **k)
            finally:
                with lock:
                    v = acc.setdefault(label, [0.0, 0.0, 0])
                    v[0] += time.thread_time() - t
                    v[1] += time.perf_counter() - w
                    v[2] += 1
        setattr(obj, name, timed)
    wrap(pb, "beam_series", "beams (active_beams)")
    wrap(mfm, "replica_spectra", "replica spectra (once)")
    wrap(mfm.sfft, "fft", "beam FFTs")
    wrap(AK, "mul_rows", "correlator: multiply")
    wrap(F.BufferedPlan, "__call__", "correlator: inverse FFT")
    wrap(AK, "power_rows", "correlator: square law")
    wrap(bk.Correlator, "__call__", "correlator (all three)")
    wrap(dt, "detect", "CFAR detection")
    wrap(dt, "cluster", "CFAR clustering")
    return acc


def make_ping(n_el: int, fs: float, seed: int):
    from arrayproc.acoustics import waveforms as wfm
    c = 1500.0
    w = wfm.bpsk(1500.0, 4.0, 2047)
    n = int(34.0 * fs)
    rng = np.random.default_rng(seed)
    x = rng.standard_normal((n, n_el)).astype(np.float32)
    pos = np.zeros((n_el, 3))
    pos[:, 0] = -0.5 * np.arange(n_el)
    cone, delay, rdot = 70.0, 10.0, 3.0
    d = (c - rdot) / (c + rdot)
    adv = (pos[:, 0] - pos[:, 0].mean()) * np.cos(np.deg2rad(cone)) / c
    i0 = int((delay - 0.1) * fs)
    t = np.arange(i0, i0 + int(4.3 * fs)) / fs
    for ch in range(n_el):
        x[i0:i0 + t.size, ch] += 0.05 * w(d * (t + adv[ch] - delay)).astype(np.float32)
    rep = SimpleNamespace(samples=w.sample(fs), fs=fs, kind="bpsk", fc=1500.0,
                          bandwidth=w.bandwidth, duration=4.0, bits=2047)
    act = SimpleNamespace(time=np.array([0.0]), waveform=["bpsk"], waveforms={"bpsk": rep},
                          projector=np.zeros(3))
    return x, pos, act, (cone, delay, rdot)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--hydrophones", type=int, default=48)
    ap.add_argument("--beams", type=int, default=360)
    ap.add_argument("--step", type=float, default=0.5, help="range-rate step, m/s (0: default)")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--ref-beams", type=int, default=4)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--json", default=None)
    ap.add_argument("--steps", action="store_true",
                    help="time each step (thread CPU summed over threads) and print its share")
    args = ap.parse_args()
    os.environ.setdefault("NUMBA_NUM_THREADS", str(args.threads))
    from arrayproc.chain import RunContext
    from arrayproc.stages.active import bank as bk
    from arrayproc.stages.active.detect import Cfar
    from arrayproc.stages.active.matched_filter import MatchedFilter
    from arrayproc.stages.active.ping_beams import ActiveBeams

    fs = 5120.0
    x, pos, act, truth = make_ping(args.hydrophones, fs, args.seed)
    rec = MemRecording(x, fs, pos, act)
    rr = {"min": -15.0, "max": 15.0} | ({"step": args.step} if args.step > 0 else {})
    beams = ActiveBeams(beams={"start": 0.0, "stop": 180.0, "count": args.beams},
                        window_s=30.0, threads=args.threads)
    mf = MatchedFilter(range_rate=rr, threads=args.threads, chunk=8)
    cfar = Cfar(method="ca", pfa=1e-6, threads=args.threads)
    ctx = RunContext(recording=rec)
    for s in (beams, mf, cfar):
        s.bind(ctx)

    # warm-up: compile the numba kernels on a small ping
    small = MemRecording(x[: int(8 * fs)], fs, pos, SimpleNamespace(
        time=np.array([0.0]), waveform=["bpsk"], waveforms=act.waveforms, projector=np.zeros(3)))
    ws = [ActiveBeams(beams={"start": 0.0, "stop": 180.0, "count": 4}, window_s=2.0),
          MatchedFilter(range_rate={"min": -1.0, "max": 1.0, "step": 0.5}), Cfar()]
    wctx = RunContext(recording=small)
    for s in ws:
        s.bind(wctx)
    list(ws[2](ws[1](ws[0](read_blocks(small, 8192)))))

    steps = instrument() if args.steps else None
    rss0 = rss_mb()
    cpu0, t0, main0 = time.process_time(), time.perf_counter(), time.thread_time()
    out = list(cfar(mf(beams(read_blocks(rec, 8192)))))
    wall, cpu = time.perf_counter() - t0, time.process_time() - cpu0
    main = time.thread_time() - main0  # the calling thread alone: the ping's serial part
    rss1 = rss_mb()
    con = out[0].meta.extra["contacts"]
    cells = int(out[0].meta.extra["cells"])
    n_rr = bk.range_rate_grid(rr, 1500.0, 4.0, 1500.0, False).size
    cube_gb = cells * 4 / 1e9
    best = int(np.argmax(con["snr_db"])) if con["snr_db"].size else None
    res = {"hydrophones": args.hydrophones, "beams": args.beams, "range_rates": n_rr,
           "cells": cells, "wall_s": wall, "cpu_s": cpu, "main_thread_cpu_s": main,
           "threads": args.threads,
           "ping_interval_s": 30.0, "peak_rss_mb": rss1, "rss_before_mb": rss0,
           "cube_float32_gb": cube_gb, "contacts": int(con["time"].size),
           "loadavg": os.getloadavg()}
    if best is not None:
        res["strongest"] = {"cone_deg": float(con["cone_deg"][best]),
                            "range_m": float(con["range_m"][best]),
                            "range_rate_mps": float(con["range_rate_mps"][best]),
                            "snr_db": float(con["snr_db"][best]),
                            "truth": {"cone_deg": truth[0], "range_m": truth[1] * 750.0,
                                      "range_rate_mps": truth[2]}}
    print(f"one ping: {args.hydrophones} hydrophones, {args.beams} beams, {n_rr} range rates, "
          f"{cells / 1e6:.0f}e6 cells: {wall:.1f} s wall, {cpu:.1f} s CPU "
          f"(ping interval 30 s); peak RSS {rss1:.0f} MB (cube alone {cube_gb:.2f} GB float32)")
    print(f"contacts {res['contacts']}; strongest {res.get('strongest')}")
    est = main + (cpu - main) / args.threads
    print(f"calling thread {main:.1f} s CPU, the other threads {cpu - main:.1f} s: on "
          f"{args.threads} free cores about {est:.1f} s per ping (serial part + the rest "
          "shared evenly; an estimate, not a measurement)")
    if steps is not None:
        res["steps"] = {k: {"cpu_s": v[0], "wall_sum_s": v[1], "calls": v[2],
                            "share": v[0] / cpu} for k, v in steps.items()}
        for k, v in steps.items():
            print(f"  {k:34s} {v[0]:7.2f} s CPU ({100 * v[0] / cpu:4.1f} % of the ping), "
                  f"{v[2]} calls")

    # matched filter alone vs plain fftconvolve, same beams and replicas
    from scipy.signal import fftconvolve
    blk = next(beams(read_blocks(rec, 8192)))
    plan = blk.meta.extra["plan"]
    rates, bank = mf._bank("bpsk", act.waveforms["bpsk"], plan.f0, plan.df, plan.n_bins)
    nb = args.ref_beams
    nl = int(blk.meta.extra["n_lags"])
    z = np.ascontiguousarray(blk.data.T[:nb])
    n_rep = int(np.ceil(4.0 / bk.doppler_scale(rates.max(), 1500.0) * plan.fs_bb)) + 2
    reps = np.fft.ifft(np.conj(bank), axis=1)[:, :n_rep].astype(np.complex64)  # p_d baseband
    t0 = time.perf_counter()
    ref = np.empty((nb, rates.size, nl), np.float32)
    for b in range(nb):
        for d in range(rates.size):
            y = fftconvolve(z[b], np.conj(reps[d][::-1]), mode="full")[n_rep - 1:]
            ref[b, d] = np.abs(y[:nl]) ** 2
    t_ref = time.perf_counter() - t0
    import scipy.fft as sfft

    from arrayproc.stages.active.bank import Correlator
    corr = Correlator(*bank.shape)
    t0 = time.perf_counter()
    ours = np.empty((nb, rates.size, nl), np.float32)
    spec = sfft.fft(z, axis=1).astype(np.complex64)
    for b in range(nb):
        corr(spec[b], bank, ours[b], 0)
    t_ours = time.perf_counter() - t0
    scale = np.max(ref) / np.max(ours)
    agree = float(np.max(np.abs(ours * scale - ref)) / np.max(ref))
    res.update(ref_beams=nb, ref_fftconvolve_s=t_ref, ours_mf_s=t_ours,
               ratio_ref_over_ours=t_ref / t_ours, max_rel_difference=agree)
    print(f"matched filter on {nb} beams x {rates.size} replicas, one thread each: "
          f"fftconvolve {t_ref:.2f} s, "
          f"ours {t_ours:.2f} s: {t_ref / t_ours:.1f}x (max difference {agree:.1e} of peak)")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(res, f, indent=2, default=float)
    sys.stdout.flush()


if __name__ == "__main__":
    main()
