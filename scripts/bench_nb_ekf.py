"""Speed of the narrowband EKF (thesis 3.2.1) on 64 channels after decimation to the tonal's
band: real-time factor of the dual re-initialised tracker (numba information-form kernel), and
its ratio to a plain numpy EKF of the same equations (information form, vectorised over the
elements, one Python iteration per sample, which is what the recursion allows numpy), timed in
the same process on the same data.

Rates: complex baseband at 5120/64 = 80 Hz (the ``dft_filter`` stage with ``complex = true``,
band 677-717 Hz) and real at 5120/3 = 1706.7 Hz (``complex = false``, the thesis's real series;
a real band at 697 Hz cannot be decimated further by that stage).

    .venv/bin/python scripts/bench_nb_ekf.py [--seconds 600] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import time

import numpy as np

from arrayproc.stages.narrowband.ekf import NarrowbandEKF

C = 1500.0
N_H = 64
X = -np.arange(N_H) * 0.36
FC = 697.5


def data(fs: float, seconds: float, cplx: bool, seed: int = 1) -> np.ndarray:
    rng = np.random.default_rng(seed)
    t = np.arange(int(seconds * fs)) / fs
    fd = 697.0 * (1 + 2.5 * math.cos(1.1) / C)
    ph = 2 * np.pi * fd * (t[:, None] + X[None, :] * math.cos(1.1) / C) + 0.3
    if cplx:
        y = np.exp(1j * (ph - 2 * np.pi * FC * t[:, None]))
        return y + 0.8 * (rng.standard_normal(y.shape) + 1j * rng.standard_normal(y.shape))
    return np.sin(ph) + 1.1 * rng.standard_normal(ph.shape)


def numpy_ekf(y: np.ndarray, fs: float, speed: float, state, cov, q, rinv, fc) -> np.ndarray:
    """The same EKF as the kernel (information form), in numpy: one iteration per sample."""
    st = np.array(state, float)
    p = np.array(cov, float)
    out = np.empty((y.shape[0], 4))
    cplx = np.iscomplexobj(y)
    dt = 1.0 / fs
    for k in range(y.shape[0]):
        tau = k * dt
        p = p + np.diag(q) * dt
        ct, sn = math.cos(st[0]), math.sin(st[0])
        a = 1 + speed * ct / C
        s = tau + X * ct / C
        ph = 2 * np.pi * st[1] * a * s
        g = np.stack([-2 * np.pi * st[1] * sn * (speed * s + a * X) / C, 2 * np.pi * a * s])
        if cplx:
            e = np.imag(y[k] * np.exp(-1j * (ph - 2 * np.pi * fc * tau))) * rinv
            w = rinv
        else:
            cs = np.cos(ph)
            e = cs * (y[k] - np.sin(ph)) * rinv
            w = cs * cs * rinv
        info = np.linalg.inv(p) + (g * w) @ g.T
        p = np.linalg.inv(info)
        st = st + p @ (g @ e)
        out[k] = st[0], st[1], p[0, 0], p[1, 1]
    return out


def bench(fs: float, cplx: bool, seconds: float, ref_seconds: float, repeats: int) -> dict:
    y = data(fs, seconds, cplx)
    block = max(1, int(round(5.0 * fs)))

    def run(threads=1):
        ekf = NarrowbandEKF(X, 64.0, 697.0, C, fc=FC if cplx else None, dual=True,
                            reinit_s=30.0, threads=threads)
        for i in range(0, y.shape[0], block):
            ekf.process(y[i:i + block], i / fs, fs, 2.5)

    run()  # compile
    best = min(_timed(run) for _ in range(repeats))
    cpu = min(_cpu(run) for _ in range(repeats))
    best2 = min(_timed(lambda: run(2)) for _ in range(repeats))
    yr = y[: int(ref_seconds * fs)]
    q = np.array([math.radians(0.05) ** 2, 1e-4])
    st0 = np.array([1.1, 697.0])
    p0 = np.diag([math.radians(2.0) ** 2, 0.25])
    rinv = np.full(N_H, 2.0)
    t_np = min(_timed(lambda: numpy_ekf(yr, fs, 2.5, st0, p0, q, rinv, FC))
               for _ in range(max(1, repeats // 2)))
    c_np = min(_cpu(lambda: numpy_ekf(yr, fs, 2.5, st0, p0, q, rinv, FC))
               for _ in range(max(1, repeats // 2)))
    # numpy per filter-sample vs numba per filter-sample (the tracker runs two filters)
    per_np = t_np / yr.shape[0]
    per_nb = best / (2 * y.shape[0])
    return {"fs_hz": fs, "complex": cplx, "channels": N_H, "seconds_of_data": seconds,
            "tracker_wall_s": best, "real_time_factor": seconds / best,
            "tracker_cpu_s": cpu, "real_time_factor_cpu": seconds / cpu,
            "tracker_wall_s_2_threads": best2, "real_time_factor_2_threads": seconds / best2,
            "numpy_seconds_of_data": ref_seconds, "numpy_wall_s": t_np, "numpy_cpu_s": c_np,
            "numpy_real_time_factor_dual": ref_seconds / (2 * t_np),
            "numpy_real_time_factor_dual_cpu": ref_seconds / (2 * c_np),
            "speedup_vs_numpy_per_filter_sample": per_np / per_nb,
            "speedup_vs_numpy_cpu": (c_np / yr.shape[0]) / (cpu / (2 * y.shape[0]))}


def _timed(f) -> float:
    """Wall time of f(), s (the machine is shared: see also ``_cpu``)."""
    t = time.perf_counter()
    f()
    return time.perf_counter() - t


def _cpu(f) -> float:
    """CPU time of this process during f(), s: less sensitive to other processes on a shared
    machine than the wall time."""
    t = time.process_time()
    f()
    return time.process_time() - t


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=600.0, help="s of data per rate")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--json")
    args = ap.parse_args(argv)
    res = {"cpus": os.cpu_count(), "load_avg_1min": os.getloadavg()[0], "runs": []}
    for fs, cplx, ref_s in ((80.0, True, 60.0), (5120.0 / 3, False, 6.0)):
        r = bench(fs, cplx, args.seconds, ref_s, args.repeats)
        res["runs"].append(r)
        print(f"{'complex' if cplx else 'real   '} {fs:7.1f} Hz x {N_H} ch, dual EKF: "
              f"{r['real_time_factor']:7.1f}x real time wall, 1 thread "
              f"({r['real_time_factor_2_threads']:.1f}x with 2; {r['real_time_factor_cpu']:.1f}x "
              f"per CPU second, 1 thread); numpy same equations "
              f"{r['numpy_real_time_factor_dual']:6.2f}x "
              f"wall ({r['numpy_real_time_factor_dual_cpu']:6.2f}x CPU); numba/numpy "
              f"{r['speedup_vs_numpy_per_filter_sample']:5.1f}x wall, "
              f"{r['speedup_vs_numpy_cpu']:5.1f}x CPU", flush=True)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(res, fh, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
