"""Where the ``cbf`` stage's time goes: CPU time per snapshot of each step, in the stream.

Runs the issue-4 configuration of ``scripts/bench_cbf.py`` (64 channels, 5120 Hz, nfft 2048,
hop 1024, 181 beams, 100-2000 Hz) through a CBF whose two phases are timed step by step with
the stage's own kernels, in the order the stage runs them: per frame windowing, FFT and
packing (front phase), per chunk of bins the corner turn, the GEMMs and the unpacking (back
phase). Prints milliseconds per snapshot for each step (summed over the workers, i.e. CPU
time), the wall time per snapshot of the whole stage, and the same for a plain ``CBF`` run
in the same process (the instrumented run is a few per cent slower).

    .venv/bin/python scripts/profile_cbf.py [--threads 1 2] [--batch 32] [--seconds 60]
"""

from __future__ import annotations

import argparse
import time
from collections import defaultdict

import numpy as np
from bench_cbf import BAND, BEAMS, HOP, NFFT, time_stage

from arrayproc.stages.beamform import _kernels as kb
from arrayproc.stages.beamform.cbf import CBF

STEPS = ("window", "fft", "pack", "corner turn", "gemm", "unpack")


class TimedCBF(CBF):
    """The stage with a clock around each step of the folded (uniform line array) path."""

    def __init__(self, **kw) -> None:
        super().__init__(**kw)
        self.t = defaultdict(float)

    def _front(self, part, frames, ops, srcs) -> None:
        plan = self._part_plan(part, srcs[0][0].shape[1])
        win, first, (pi, pj) = self._win_cast(), int(self._bins[0]), self._pairs
        t = self.t
        for s in frames:
            t0 = time.perf_counter()
            kb.window_frame(srcs[s][0], srcs[s][1], win, plan.input)
            t1 = time.perf_counter()
            spec = plan()
            t2 = time.perf_counter()
            kb.pack_fold(spec, first, pi, pj, ops[0][s], ops[1][s])
            t3 = time.perf_counter()
            t["window"] += t1 - t0
            t["fft"] += t2 - t1
            t["pack"] += t3 - t2

    def _back(self, part, chunks, ops, y) -> None:
        w = self._results(part, y.shape[0], ops[0].shape[3])
        chunk, nf, t = w[0].shape[0], y.shape[1], self.t
        for c in chunks:
            n = min(nf, c + chunk) - c
            t0 = time.perf_counter()
            kb.gather_bins(ops[0], c, w[0][:n])
            kb.gather_bins(ops[1], c, w[1][:n])
            t1 = time.perf_counter()
            za = np.matmul(w[0][:n], self._steer[0][c:c + n], out=w[2][:n])
            zb = np.matmul(w[1][:n], self._steer[1][c:c + n], out=w[3][:n])
            t2 = time.perf_counter()
            kb.unpack_fold(za, zb, self._runs, y, c)
            t3 = time.perf_counter()
            t["corner turn"] += t1 - t0
            t["gemm"] += t2 - t1
            t["unpack"] += t3 - t2



def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--batch", type=int, default=32)
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    n_snap = int((args.seconds * 5120 - NFFT) // HOP) + 1
    kw = dict(nfft=NFFT, hop=HOP, window="hann", band=list(BAND), beams=BEAMS,
              batch=args.batch)
    print(f"ms per snapshot; {n_snap} snapshots per run, best of {args.repeat}")
    print(f"{'threads':>7s} {'stage':>7s} {'timed':>7s} | " + " ".join(f"{s:>11s}" for s in STEPS)
          + f" | {'CPU sum':>7s}")
    for th in args.threads:
        plain, timed = CBF(threads=th, **kw), TimedCBF(threads=th, **kw)
        for st in (plain, timed):  # warm-up: numba cache, FFT plan timing, buffers
            time_stage(st, 5.0)
            time_stage(st, args.seconds)
        walls, twalls, best = [], [], None
        for _ in range(args.repeat):
            walls.append(time_stage(plain, args.seconds))
            timed.t.clear()
            twalls.append(time_stage(timed, args.seconds))
            if twalls[-1] == min(twalls):
                best = dict(timed.t)
        row = [best.get(s, 0.0) / n_snap * 1e3 for s in STEPS]
        print(f"{th:7d} {min(walls) / n_snap * 1e3:7.3f} {min(twalls) / n_snap * 1e3:7.3f} | "
              + " ".join(f"{v:11.3f}" for v in row) + f" | {sum(row):7.3f}")


if __name__ == "__main__":
    main()
