#!/usr/bin/env python
"""Throughput of our UKF against filterpy's UKF on the L-R paper's Case I.

Both run the same scenario (31 bearings, known side) back to back in this process: ours as
the numba Monte Carlo kernel (runs in parallel on the available cores), filterpy's as its
Python UKF, one run after another. Prints runs/second and the ratio. Also times our
per-step Python interface (the ``UKF`` class) for reference.

    python scripts/bench_track.py [--runs 20000] [--fp-runs 100] [--json OUT]

``--cpu RUNS`` only times the fused L-R kernel on one thread (CPU ms per run, min of 5
repeats) for paired A/B comparisons with another checkout:

    PYTHONPATH=/tmp/wt_before python scripts/bench_track.py --cpu 600
    PYTHONPATH=. python scripts/bench_track.py --cpu 600
"""

from __future__ import annotations

import argparse
import json
import math
import time

import numpy as np
from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter

from arrayproc.evaluate.montecarlo import LRScenario, run_case

# the component imports are inside the functions that use them, so that ``--cpu`` also runs
# against a checkout from before the components (paired A/B)


def filterpy_runs(scn: LRScenario, y1: np.ndarray, draws: np.ndarray) -> float:
    """Seconds for filterpy's UKF over every row of y1."""
    from arrayproc.track.init import init_from_bearing
    from arrayproc.track.models.bearing import bearing_residual, bearing_sigma_mean
    from arrayproc.track.models.motion import constant_velocity
    from arrayproc.track.state import Context

    g = scn.geometry()
    model = constant_velocity()
    pts = MerweScaledSigmaPoints(4, alpha=1.0, beta=0.0, kappa=-1.0)
    R = np.array([[math.radians(scn.sigma_deg) ** 2]])
    Q = model.covariance(scn.dt)

    def fx(x, dt, o0, o1):
        return model.function(x, dt, Context(o1, o0))

    def hx(x):
        return np.array([math.atan2(x[0], x[1])])

    t0 = time.perf_counter()
    for r in range(y1.shape[0]):
        x0, P0 = init_from_bearing(math.degrees(y1[r, 0]), g["own"][0], scn.prior, 4)
        f = UnscentedKalmanFilter(4, 1, scn.dt, hx, fx, pts, z_mean_fn=bearing_sigma_mean,
                                  residual_z=bearing_residual)
        f.x, f.P, f.R, f.Q = x0, P0, R, Q
        for k in range(1, y1.shape[1]):
            f.predict(o0=g["own"][k - 1], o1=g["own"][k])
            f.update(np.array([y1[r, k]]))
    return time.perf_counter() - t0


def class_runs(scn: LRScenario, y1: np.ndarray) -> float:
    """Seconds for our per-step UKF object (predict/update with the bearing model) over every
    row of y1."""
    from arrayproc.track.filters import UKF
    from arrayproc.track.init import init_from_bearing
    from arrayproc.track.models.bearing import Bearing
    from arrayproc.track.models.motion import constant_velocity
    from arrayproc.track.state import Context

    g = scn.geometry()
    model = constant_velocity()
    meas = Bearing(sigma_deg=scn.sigma_deg)
    ctxs = [Context(g["own"][k], g["own"][k - 1]) for k in range(1, y1.shape[1])]
    f = UKF()
    t0 = time.perf_counter()
    for r in range(y1.shape[0]):
        s = f.initialize(*init_from_bearing(math.degrees(y1[r, 0]), g["own"][0], scn.prior, 4))
        for k in range(1, y1.shape[1]):
            s, _ = f.update(f.predict(s, model, scn.dt, ctxs[k - 1]), y1[r, k], meas,
                            ctxs[k - 1])
    return time.perf_counter() - t0


def cpu_per_run(runs: int, repeats: int = 5) -> dict[str, float]:
    """CPU ms per run (min of ``repeats``) of the fused L-R kernel, resolved, one thread, for
    EKF/UKF/GHF on Cases I and II. Uses only ``run_case``, so the same script times an older
    checkout: ``PYTHONPATH=<checkout> python scripts/bench_track.py --cpu 600`` (paired A/B)."""
    out = {}
    for case in (1, 2):
        scn = LRScenario(case=case)
        meas = scn.measurements(runs, 5)
        for name in ("ukf", "ghf", "ekf"):
            run_case(scn, name, True, 4, 0, meas=tuple(m[:4] for m in meas), threads=1)
            best = math.inf
            for _ in range(repeats):
                c = time.process_time()
                run_case(scn, name, True, runs, 0, meas=meas, threads=1)
                best = min(best, time.process_time() - c)
            out[f"case{case}_{name}_cpu_ms_per_run"] = 1e3 * best / runs
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cpu", type=int, default=0, metavar="RUNS",
                    help="only the one-thread CPU time per run of the fused L-R kernel "
                         "(min of 5 repeats of RUNS runs), for paired A/B comparisons")
    ap.add_argument("--runs", type=int, default=20000, help="runs for our kernel")
    ap.add_argument("--fp-runs", type=int, default=100, help="runs for filterpy")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--json", help="write the numbers here")
    a = ap.parse_args(argv)
    if a.cpu:
        res = cpu_per_run(a.cpu)
        for k, v in res.items():
            print(f"{k:<32}{v:10.3f}")
        if a.json:
            with open(a.json, "w") as fh:
                json.dump(res, fh, indent=2)
        return 0
    scn = LRScenario(case=1, random_init=False)
    meas = scn.measurements(a.runs, a.seed)
    run_case(scn, "ukf", False, 4, a.seed)  # compile / load the cache
    res = run_case(scn, "ukf", False, a.runs, a.seed, meas=meas)
    ours = a.runs / res.seconds
    y1 = meas[0][: a.fp_runs]
    cls = a.fp_runs / class_runs(scn, y1)
    fp = a.fp_runs / filterpy_runs(scn, y1, meas[2])
    out = {"scenario": "L-R paper Case I, 31 bearings, known side",
           "ours_kernel_runs_per_s": ours, "ours_class_runs_per_s": cls,
           "filterpy_runs_per_s": fp, "ratio_kernel_vs_filterpy": ours / fp,
           "ratio_class_vs_filterpy": cls / fp, "runs": a.runs, "fp_runs": a.fp_runs}
    print(f"{'implementation':<34}{'runs/s':>12}{'× filterpy':>12}")
    print(f"{'arrayproc UKF (numba MC kernel)':<34}{ours:>12.0f}{ours / fp:>12.1f}")
    print(f"{'arrayproc UKF (per-step class)':<34}{cls:>12.0f}{cls / fp:>12.1f}")
    print(f"{'filterpy UnscentedKalmanFilter':<34}{fp:>12.1f}{1.0:>12.1f}")
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(out, fh, indent=2)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
