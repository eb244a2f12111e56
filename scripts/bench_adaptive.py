"""Benchmark of the ``mvdr`` stage against a batched numpy MVDR in the same process.

Configuration: 64 channels, 5120 Hz, nfft 2048, hop 1024, 181 cone-angle beams 0..180°, band
100-2000 Hz (761 bins), Hann window, ``--snapshots`` per covariance (default 64), loading
0.01, float32 white-noise time blocks of 8192 samples from a generator (no disk I/O), as the
chain reader would feed them.

Reference (``numpy_ref``): per covariance group the same frames, ``np.fft.rfft`` of the
windowed frames of the whole group at once, the band's bins, R = X X^H / K as one batched
``np.matmul`` over the bins (complex128), diagonal loading, ``np.linalg.inv`` over the bins,
then P = N² / Re(a^H R⁻¹ a) for all beams as batched ``R⁻¹ @ A`` and a sum over elements with
a precomputed steering tensor A (F, C, B); numpy's own threading (OpenBLAS) as it comes.

Printed (and written with ``--json``): for the stage (``threads`` = 2, the lag path of a
uniform line array), the stage forced onto its general GEMM path (elements jittered along the
axis by 1 mm, so no co-array lags), and the reference: data seconds, wall seconds, CPU seconds
(process time, all threads), the multiple of real time by wall clock and by CPU time per core
(data s × cores / CPU s), and the ratios stage/reference; also the largest relative
difference between the stage's and the reference's powers on the same data (a check that the
two compute the same thing; the general path's geometry differs, so it is not compared).
The machine is shared: the 1-minute load average is printed, and
CPU time is the figure to compare.

    PYTHONPATH=. .venv/bin/python scripts/bench_adaptive.py [--seconds 64] [--repeat 2]
        [--snapshots 64] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import bench_cbf  # noqa: E402  (same folder: its noise blocks)

from arrayproc.dsp.windows import time_taper
from arrayproc.io.geometry import line_array
from arrayproc.stages.beamform.mvdr import MVDR

# the CBF benchmark's configuration (scripts/bench_cbf.py): same data, same beams
FS, N_CH, NFFT, HOP = bench_cbf.FS, bench_cbf.N_CH, bench_cbf.NFFT, bench_cbf.HOP
BAND, BEAMS, C = bench_cbf.BAND, bench_cbf.BEAMS, bench_cbf.C
LOADING = 0.01


def source(seconds: float, positions: np.ndarray):
    """The CBF benchmark's white-noise time blocks (scripts/bench_cbf.py) at ``positions``."""
    for b in bench_cbf.source(seconds):
        yield b.replace(positions=positions)


def run_stage(seconds: float, positions: np.ndarray, snapshots: int) -> tuple[list, float,
                                                                              float]:
    st = MVDR(nfft=NFFT, hop=HOP, band=list(BAND), beams=BEAMS, snapshots=snapshots,
              loading=LOADING, threads=2)
    t_w, t_c = time.perf_counter(), time.process_time()
    out = [b.data[0] for b in st.process(source(seconds, positions))]
    return out, time.perf_counter() - t_w, time.process_time() - t_c


def run_reference(seconds: float, positions: np.ndarray, snapshots: int) -> tuple[list, float,
                                                                                  float]:
    """The batched numpy MVDR of the module doc, over the same frames (groups aligned on the
    snapshot grid as the stage's)."""
    f = np.fft.rfftfreq(NFFT, 1 / FS)
    sel = np.flatnonzero((f >= BAND[0]) & (f <= BAND[1]))
    cone = np.linspace(BEAMS["start"], BEAMS["stop"], BEAMS["count"])
    rel = positions - positions.mean(axis=0)
    tau = np.cos(np.deg2rad(cone))[:, None] * rel[None, :, 0] / C  # (B, C)
    a = np.exp(2j * np.pi * f[sel, None, None] * tau.T[None])  # (F, C, B)
    win = time_taper("hann", NFFT)
    t_w, t_c = time.perf_counter(), time.process_time()
    data = np.concatenate([b.data for b in source(seconds, positions)])
    out = []
    n_frames = (data.shape[0] - NFFT) // HOP + 1
    for g in range(n_frames // snapshots):
        idx = (g * snapshots + np.arange(snapshots))[:, None] * HOP + np.arange(NFFT)[None]
        frames = data[idx] * win[None, :, None]  # (K, nfft, C)
        x = np.fft.rfft(frames, axis=1)[:, sel, :].transpose(1, 2, 0)  # (F, C, K)
        r = x @ x.conj().transpose(0, 2, 1) / snapshots
        sigma = np.real(np.trace(r, axis1=1, axis2=2)) / N_CH
        r[:, np.arange(N_CH), np.arange(N_CH)] += (LOADING * sigma)[:, None]
        q = np.linalg.inv(r)
        form = np.einsum("fcb,fcb->fb", a.conj(), q @ a).real
        out.append(N_CH**2 / form)
    return out, time.perf_counter() - t_w, time.process_time() - t_c


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seconds", type=float, default=64.0)
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--snapshots", type=int, default=64)
    ap.add_argument("--json")
    args = ap.parse_args()
    pos = line_array(N_CH, 0.36)
    jitter = pos.copy()
    jitter[:, 0] += np.random.default_rng(0).normal(0, 1e-3, N_CH)  # off the lag grid
    res: dict = {"config": dict(channels=N_CH, fs=FS, nfft=NFFT, hop=HOP, band=BAND,
                                beams=BEAMS["count"], snapshots=args.snapshots,
                                seconds=args.seconds, load_1min=os.getloadavg()[0])}
    run_stage(4 * args.snapshots * HOP / FS, pos, args.snapshots)  # compile / warm caches
    best: dict = {}
    outs: dict = {}
    for _ in range(args.repeat):
        for name, fn, p in (("stage", run_stage, pos), ("stage_general", run_stage, jitter),
                            ("numpy_ref", run_reference, pos)):
            out, wall, cpu = fn(args.seconds, p, args.snapshots)
            outs[name] = out
            if name not in best or cpu < best[name][1]:
                best[name] = (wall, cpu)
    for name, (wall, cpu) in best.items():
        res[name] = dict(wall_s=wall, cpu_s=cpu, rt_wall=args.seconds / wall,
                         rt_cpu_per_core=args.seconds * 2 / cpu,
                         cpu_s_per_data_s=cpu / args.seconds)
    for name in ("stage", "stage_general"):
        res[f"{name}_over_ref_cpu"] = best["numpy_ref"][1] / best[name][1]
        res[f"{name}_over_ref_wall"] = best["numpy_ref"][0] / best[name][0]
    n = min(len(outs["stage"]), len(outs["numpy_ref"]))
    res["groups"] = n
    res["stage_max_rel_diff"] = max(
        float(np.max(np.abs(outs["stage"][i] / outs["numpy_ref"][i] - 1))) for i in range(n))
    res["load_1min_after"] = os.getloadavg()[0]
    for k, v in res.items():
        print(f"{k}: {v}")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(res, fh, indent=1, default=float)


if __name__ == "__main__":
    main()
