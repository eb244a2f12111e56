"""Benchmark of the ``cbf`` stage against a plain per-snapshot numpy CBF.

Configuration: 64 channels, 5120 Hz, nfft 2048, hop 1024, 181 cone-angle beams
0..180°, band 100-2000 Hz (761 bins), Hann window, float32 data. The stage is fed 8192-sample
time blocks of white noise from a generator (no disk I/O), exactly as the chain reader would.

Printed (and written with ``--json``):

- ``cbf``: multiples of real time of the stage (data seconds / wall seconds), best of
  ``--repeat`` runs over ``--seconds`` of data, and the same for ``cbf + integrate`` (N_B = 8);
- ``numpy_ref``: the same for a plain numpy CBF, one snapshot at a time (``np.fft.rfft`` of
  the windowed frame, then ``np.einsum("fbc,fc->fb", steering, spectrum)`` with a precomputed
  steering matrix; numpy's default complex128, and a complex64 variant), measured in the
  same process on ``--ref-snapshots`` snapshots, interleaved with the stage's runs;
- a well-batched plain numpy CBF (64 snapshots per ``np.matmul`` over the bins, complex64),
  the issue's yardstick "for scale";
- the ratio of the stage to each;
- peak traced memory (tracemalloc: numpy allocations included) of a fresh stage over two data
  lengths, and the peak RSS of a fresh process over 1/4 and 4 times ``--seconds``, to show
  memory does not grow with the length of the input.

The 1-minute load average is printed with the results: the machine is shared.

    .venv/bin/python scripts/bench_cbf.py [--seconds 60] [--repeat 3] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import os
import time
import tracemalloc

import numpy as np

from arrayproc.chain.block import Block
from arrayproc.chain.domains import Domain, TimeMeta
from arrayproc.dsp.windows import time_taper as time_window
from arrayproc.io.geometry import line_array
from arrayproc.stages.beamform.cbf import CBF
from arrayproc.stages.passive.integrate import Integrate

FS = 5120.0
N_CH = 64
NFFT = 2048
HOP = 1024
BAND = (100.0, 2000.0)
BEAMS = {"start": 0.0, "stop": 180.0, "count": 181}
BLOCK = 8192
C = 1500.0
BLAS_SETTLE_S = 0.5  # pause after numpy's multithreaded GEMM (its threads spin when idle)


_POOL = [np.random.default_rng(k).standard_normal((BLOCK, N_CH)).astype(np.float32)
         for k in range(4)]


def source(seconds: float):
    """Time blocks of white noise, cycling over a few pre-drawn blocks (bounded memory)."""
    pool = _POOL
    pos = line_array(N_CH, 0.36)
    n_blocks = int(np.ceil(seconds * FS / BLOCK))
    for k in range(n_blocks):
        yield Block(pool[k % 4], Domain.TIME, k * BLOCK / FS, BLOCK / FS, FS, pos, None,
                    index=k, meta=TimeMeta(k * BLOCK, BLOCK))


_STAGES: dict[int, CBF] = {}


def make_stage(threads: int) -> CBF:
    """One stage per thread count, kept warm: its steering matrix is built on first use
    (about 0.2 s, once per stream) and is not part of the steady-state throughput."""
    if threads not in _STAGES:
        _STAGES[threads] = CBF(nfft=NFFT, hop=HOP, window="hann", band=list(BAND),
                               beams=BEAMS, threads=threads)
    return _STAGES[threads]


_CPU: dict[str, list[float]] = {}


def time_stage(stage, seconds: float, src=None) -> float:
    """Wall time (s) of ``stage.process`` over ``seconds`` of :func:`source` data (or of
    ``src(seconds)``)."""
    blocks = (src or source)(seconds)
    t = time.perf_counter()
    for _ in stage.process(blocks):
        pass
    return time.perf_counter() - t


def run_stage(seconds: float, integrate: bool = False, threads: int = 0) -> float:
    """Wall time (s) of the cbf stage (optionally + integrate) over ``seconds`` of data; the
    process CPU time (all threads) is recorded in ``_CPU``."""
    it = make_stage(threads).process(source(seconds))
    if integrate:
        it = Integrate(snapshots=8, mode="blockwise").process(it)
    c = time.process_time()
    t = time.perf_counter()
    for _ in it:
        pass
    wall = time.perf_counter() - t
    _CPU.setdefault("integrate" if integrate else "cbf", []).append(time.process_time() - c)
    return wall


def numpy_reference(n_snap: int, single: bool = False) -> float:
    """Seconds per snapshot of the plain per-snapshot numpy CBF: numpy's default dtypes
    (``np.fft.rfft`` returns complex128, ``np.exp`` gives a complex128 steering matrix), or
    with ``single`` the spectrum and steering cast to complex64."""
    rng = np.random.default_rng(1)
    x = rng.standard_normal(((n_snap + 1) * HOP, N_CH)).astype(np.float32)
    pos = line_array(N_CH, 0.36)
    w = time_window("hann", NFFT).astype(np.float32)
    f = np.fft.rfftfreq(NFFT, 1 / FS)
    sel = (f >= BAND[0]) & (f <= BAND[1])
    cone = np.linspace(BEAMS["start"], BEAMS["stop"], BEAMS["count"])
    tau = np.cos(np.deg2rad(cone))[:, None] * (pos[:, 0] - pos[:, 0].mean())[None, :] / C
    steer = np.exp(-2j * np.pi * f[sel, None, None] * tau[None])
    if single:
        steer = steer.astype(np.complex64)
    c = time.process_time()
    t = time.perf_counter()
    for s in range(n_snap):
        frame = x[s * HOP:s * HOP + NFFT]
        spec = np.fft.rfft(frame * w[:, None], axis=0)[sel]
        if single:
            spec = spec.astype(np.complex64)
        np.einsum("fbc,fc->fb", steer, spec)
    wall = (time.perf_counter() - t) / n_snap
    _CPU.setdefault("ref32" if single else "ref", []).append((time.process_time() - c) / n_snap)
    return wall


def numpy_batched(n_snap: int, batch: int = 64) -> float:
    """Seconds per snapshot of a well-batched plain numpy CBF: ``batch`` windowed frames
    transformed at once (``np.fft.rfft``, complex64 from float32 input), the band's bins
    transposed to (F, S, C) and multiplied by the complex64 steering matrix (F, C, B) in one
    batched ``np.matmul`` (complex GEMM per bin, numpy's BLAS with its default threads). This
    is the "well-batched numpy GEMM over many snapshots" the issue quotes for scale."""
    rng = np.random.default_rng(2)
    n_snap = max(batch, n_snap - n_snap % batch)
    x = rng.standard_normal(((n_snap + 1) * HOP, N_CH)).astype(np.float32)
    pos = line_array(N_CH, 0.36)
    w = time_window("hann", NFFT).astype(np.float32)
    f = np.fft.rfftfreq(NFFT, 1 / FS)
    sel = np.flatnonzero((f >= BAND[0]) & (f <= BAND[1]))
    cone = np.linspace(BEAMS["start"], BEAMS["stop"], BEAMS["count"])
    tau = np.cos(np.deg2rad(cone))[None, :] * (pos[:, 0] - pos[:, 0].mean())[:, None] / C
    steer = np.exp(-2j * np.pi * f[sel, None, None] * tau[None]).astype(np.complex64)  # F,C,B
    idx = np.arange(NFFT)[None, :] + HOP * np.arange(batch)[:, None]  # (S, nfft)
    c = time.process_time()
    t = time.perf_counter()
    for a in range(0, n_snap, batch):
        frames = x[a * HOP + idx] * w[None, :, None]  # (S, nfft, C)
        spec = np.fft.rfft(frames, axis=1)[:, sel]  # (S, F, C)
        np.matmul(spec.transpose(1, 0, 2), steer)  # (F, S, B)
    wall = (time.perf_counter() - t) / n_snap
    _CPU.setdefault("batched", []).append((time.process_time() - c) / n_snap)
    return wall


def bench_dft_filter(seconds: float, repeat: int) -> dict:
    """``dft_filter`` (band 100-2000 Hz, α 0.1; and 100-1200 Hz decimated by 2) on the same
    blocks, against ``scipy.signal.oaconvolve`` of the same taps over the whole signal in
    one call (not streaming), both in × real time (best of ``repeat``)."""
    from scipy import signal

    from arrayproc.stages.condition.dft_filter import DFTFilter
    out = {}
    x = np.concatenate([_POOL[k % 4] for k in range(int(np.ceil(seconds * FS / BLOCK)))])
    for band, d in (([100.0, 2000.0], 1), ([100.0, 1200.0], 2)):
        st = DFTFilter(band=band, taper=0.1, decimate=d)
        for _ in st.process(source(5.0)):
            pass
        best = np.inf
        best_ref = np.inf
        for _ in range(repeat):
            t = time.perf_counter()
            for _ in st.process(source(seconds)):
                pass
            best = min(best, time.perf_counter() - t)
            t = time.perf_counter()
            signal.oaconvolve(x, st.taps[:, None].astype(np.float32), mode="same",
                              axes=0)[::d]
            best_ref = min(best_ref, time.perf_counter() - t)
        out[f"{band[0]:g}-{band[1]:g} Hz /{d}"] = {
            "taps": int(st.taps.size), "x_realtime": seconds / best,
            "scipy_oaconvolve_x_realtime": x.shape[0] / FS / best_ref}
    return out


def peak_memory(seconds: float) -> float:
    """Peak traced memory (MB: numpy and Python allocations) of a fresh stage running over
    ``seconds`` of data, set-up (steering matrix, FFT buffers) included."""
    _STAGES.clear()
    tracemalloc.start()
    tracemalloc.reset_peak()
    run_stage(seconds)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    return peak / 1e6


def peak_rss_child(seconds: float) -> float:
    """Peak resident set size (MB) of a fresh Python process running the stage over
    ``seconds`` of data (everything: interpreter, libraries, buffers)."""
    import subprocess
    import sys
    out = subprocess.run([sys.executable, __file__, "--rss-child", str(seconds)],
                         capture_output=True, text=True, check=True)
    return float(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=60.0, help="data seconds per run")
    ap.add_argument("--repeat", type=int, default=3, help="runs (best is kept)")
    ap.add_argument("--ref-snapshots", type=int, default=40)
    ap.add_argument("--threads", type=int, default=0, help="CBF worker threads (0: all)")
    ap.add_argument("--json", default=None, help="write the figures to this JSON file")
    ap.add_argument("--rss-child", type=float, default=None, help=argparse.SUPPRESS)
    ap.add_argument("--dft", action="store_true", help="also bench the dft_filter stage")
    args = ap.parse_args()
    if args.rss_child is not None:
        import resource
        run_stage(args.rss_child)
        print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0)
        return

    t = time.perf_counter()
    run_stage(5.0, threads=args.threads)  # warm-up: numba cache, FFTW plans, steering
    setup = time.perf_counter() - t
    snaps_per_s = FS / HOP
    ref_s = []
    ref32_s = []
    cbf_s = []
    both_s = []
    batched_s = []
    for _ in range(args.repeat):  # interleaved, so both see the same machine load
        ref_s.append(numpy_reference(args.ref_snapshots))
        ref32_s.append(numpy_reference(args.ref_snapshots, single=True))
        batched_s.append(numpy_batched(max(128, 4 * args.ref_snapshots)))
        # OpenBLAS's threads busy-wait for a while after a multithreaded GEMM returns; a run
        # started at once shares the two cores with them (10-13 % slower, measured)
        time.sleep(BLAS_SETTLE_S)
        cbf_s.append(run_stage(args.seconds, threads=args.threads))
        both_s.append(run_stage(args.seconds, integrate=True, threads=args.threads))
    rt_cbf = args.seconds / min(cbf_s)
    rt_both = args.seconds / min(both_s)
    rt_ref = 1.0 / (min(ref_s) * snaps_per_s)
    rt_ref32 = 1.0 / (min(ref32_s) * snaps_per_s)
    rt_batched = 1.0 / (min(batched_s) * snaps_per_s)
    mem_short = peak_memory(args.seconds / 2)
    mem_long = peak_memory(args.seconds * 2)
    rss = {f"{sec:g}s": peak_rss_child(sec) for sec in (args.seconds / 4, args.seconds * 4)}
    # CPU time (all threads): data seconds per CPU second, insensitive to how many cores the
    # machine's load left us (the first run of each list may include warm-up effects)
    cpu_cbf = args.seconds / min(_CPU["cbf"][-args.repeat:])
    cpu_ref = 1.0 / (min(_CPU["ref"]) * snaps_per_s)
    res = {
        "config": {"channels": N_CH, "fs_hz": FS, "nfft": NFFT, "hop": HOP,
                   "beams": BEAMS["count"], "band_hz": list(BAND), "bins": 761,
                   "dtype": "float32", "threads": args.threads or os.cpu_count()},
        "cbf_x_realtime": rt_cbf,
        "cbf_integrate_x_realtime": rt_both,
        "numpy_ref_x_realtime": rt_ref,
        "ratio_cbf_to_numpy_ref": rt_cbf / rt_ref,
        "numpy_ref_complex64_x_realtime": rt_ref32,
        "ratio_cbf_to_numpy_ref_complex64": rt_cbf / rt_ref32,
        "numpy_batched_gemm_x_realtime": rt_batched,
        "ratio_cbf_to_numpy_batched_gemm": rt_cbf / rt_batched,
        "peak_traced_mb": {f"{args.seconds / 2:g}s": mem_short,
                           f"{args.seconds * 2:g}s": mem_long},
        "peak_rss_mb": rss,
        "cpu_cbf_x_realtime_per_cpu_second": cpu_cbf,
        "cpu_numpy_ref_x_realtime_per_cpu_second": cpu_ref,
        "cpu_ratio": cpu_cbf / cpu_ref,
        "first_run_5s_wall_s": setup,
        "load_avg_1min": os.getloadavg()[0],
        "cpu_count": os.cpu_count(),
    }
    print(f"CBF bench: {N_CH} ch, {FS:g} Hz, nfft {NFFT}, hop {HOP}, {BEAMS['count']} beams, "
          f"{BAND[0]:g}-{BAND[1]:g} Hz, float32, {res['config']['threads']} threads")
    print(f"{'':24s}{'x real time':>14s}")
    print(f"{'cbf stage':24s}{rt_cbf:14.1f}")
    print(f"{'cbf + integrate':24s}{rt_both:14.1f}")
    print(f"{'numpy per-snapshot ref':24s}{rt_ref:14.2f}")
    print(f"{'  same, complex64':24s}{rt_ref32:14.2f}")
    print(f"{'numpy batched GEMM':24s}{rt_batched:14.1f}")
    print(f"ratio cbf / numpy ref: {rt_cbf / rt_ref:.1f} (complex64 ref: {rt_cbf / rt_ref32:.1f}"
          f"; batched numpy GEMM: {rt_cbf / rt_batched:.1f})")
    print(f"CPU time (all threads): cbf {cpu_cbf:.1f}x real time per CPU second, numpy ref "
          f"{cpu_ref:.2f}x, ratio {cpu_cbf / cpu_ref:.1f}")
    print("peak traced memory (fresh stage): " + ", ".join(
        f"{k} of data: {v:.0f} MB" for k, v in res["peak_traced_mb"].items()))
    print("peak RSS of a fresh process: " + ", ".join(
        f"{k} of data: {v:.0f} MB" for k, v in res["peak_rss_mb"].items()))
    print(f"load average (1 min) at the end: {res['load_avg_1min']:.2f} on "
          f"{os.cpu_count()} cores")
    if args.dft:
        res["dft_filter"] = bench_dft_filter(min(args.seconds, 30.0), args.repeat)
        for k, v in res["dft_filter"].items():
            print(f"dft_filter {k}: {v['taps']} taps, {v['x_realtime']:.1f}x real time "
                  f"(scipy.signal.oaconvolve, one call: {v['scipy_oaconvolve_x_realtime']:.1f}x)")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(res, f, indent=2)


if __name__ == "__main__":
    main()
