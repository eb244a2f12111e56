#!/usr/bin/env python
"""Bearings-only particle filtering: arrayproc's RPF against Stone Soup's particle filter on the
same measurements (SPL paper manoeuvring scenario, N particles, resampling when
N_eff < N/3, systematic).

Stone Soup (benchmark-only dependency, ``pip install stonesoup``) runs its ParticlePredictor /
ParticleUpdater with ESSResampler(threshold N/3, SystematicResampler) and its MCMCRegulariser
(its regularisation step), a constant-velocity model with q = σ_a²·Δt (same velocity noise per
step as ours), the Cartesian2DToBearing model with the observer position as translation offset,
and the same prior draw (range, bearing, speed, course) as ours. Bearings are converted from
true bearings (clockwise from north) to Stone Soup's atan2(y, x).

Prints runs/s for both and the RMSE over the runs both filters saw.

Usage: python scripts/bench_pf.py [--runs-ss 20] [--runs 1000] [--particles 5000] [--json OUT]
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import time
from pathlib import Path

import numba
import numpy as np

from arrayproc.acoustics.tl import load_default_table
from arrayproc.evaluate.scenarios import get_scenario
from arrayproc.track.filters.particle import RegularizedParticleFilter, RPFConfig, run_seeds


def stonesoup_run(sc, times, obs, bearings_deg, n, seed):
    """One Stone Soup bearings-only PF run; returns estimates (K, 4) as [x, y, vx, vy]."""
    from stonesoup.models.measurement.nonlinear import Cartesian2DToBearing
    from stonesoup.models.transition.linear import (
        CombinedLinearGaussianTransitionModel,
        ConstantVelocity,
    )
    from stonesoup.predictor.particle import ParticlePredictor
    from stonesoup.regulariser.particle import MCMCRegulariser
    from stonesoup.resampler.particle import ESSResampler, SystematicResampler
    from stonesoup.types.array import StateVectors
    from stonesoup.types.detection import Detection
    from stonesoup.types.hypothesis import SingleHypothesis
    from stonesoup.types.state import ParticleState
    from stonesoup.updater.particle import ParticleUpdater

    rng = np.random.default_rng(seed)
    np.random.seed(seed % 2**32)  # noqa: NPY002 (Stone Soup draws from the global RNG)
    sig = np.deg2rad(sc.sigma_bearing_deg)
    q = 1.5e-3**2 * (times[1] - times[0])
    trans = CombinedLinearGaussianTransitionModel([ConstantVelocity(q), ConstantVelocity(q)])
    predictor = ParticlePredictor(trans)
    updater = ParticleUpdater(measurement_model=None,
                              resampler=ESSResampler(threshold=n / 3.0,
                                                     resampler=SystematicResampler()),
                              regulariser=MCMCRegulariser(transition_model=trans))
    b0 = np.deg2rad(bearings_deg[0])
    r = np.maximum(sc.range_prior_m[0] + sc.range_prior_m[1] * rng.standard_normal(n), 100.0)
    b = b0 + sig * rng.standard_normal(n)
    s = sc.speed_prior[0] + sc.speed_prior[1] * rng.standard_normal(n)
    c = b0 + np.pi + sc.course_std_rad * rng.standard_normal(n)
    sv = StateVectors([obs[0, 0] + r * np.sin(b), s * np.sin(c), obs[0, 1] + r * np.cos(b),
                       s * np.cos(c)])
    t0 = dt.datetime(2024, 1, 1)
    state = ParticleState(sv, weight=np.full(n, 1.0 / n), timestamp=t0)
    est = np.empty((times.size, 4))
    m = np.asarray(state.mean).ravel()
    est[0] = m[[0, 2, 1, 3]]
    for k in range(1, times.size):
        ts = t0 + dt.timedelta(seconds=float(times[k]))
        model = Cartesian2DToBearing(ndim_state=4, mapping=(0, 2), noise_covar=np.array([[sig**2]]),
                                     translation_offset=np.array([[obs[k, 0]], [obs[k, 1]]]))
        phi = np.pi / 2 - np.deg2rad(bearings_deg[k])
        det = Detection(np.array([[np.arctan2(np.sin(phi), np.cos(phi))]]), timestamp=ts,
                        measurement_model=model)
        pred = predictor.predict(state, timestamp=ts)
        state = updater.update(SingleHypothesis(pred, det))
        m = np.asarray(state.mean).ravel()
        est[k] = m[[0, 2, 1, 3]]
    return est


def speed_spl(name: str, runs: int, n: int, seed: int) -> dict:
    """Wall and CPU time of ``runs`` bearings+SPL RPF runs (all threads of this process)."""
    sc = get_scenario(name)
    tab = load_default_table()
    data = sc.simulate(runs, seed, tab)
    f = RegularizedParticleFilter(RPFConfig(n_particles=n, use_levels=True, tl_table=tab))
    f.run_many(data.times[:3], data.observer_pos[:3], data.bearings_deg[:1, :3],
               data.levels_db[:1, :3])
    c0, t0 = time.process_time(), time.perf_counter()
    f.run_many(data.times, data.observer_pos, data.bearings_deg, data.levels_db, seed=seed)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    steps = data.times.size
    load = os.getloadavg()[0]
    print(f"bearings+SPL RPF, {name}: {runs} runs x {steps} steps x N = {n}: wall {wall:.1f} s "
          f"on {numba.get_num_threads()} threads, CPU {cpu:.1f} s "
          f"({cpu / (runs * steps * n) * 1e9:.0f} ns per particle-step; "
          f"{cpu / 2:.1f} s if two cores were ours alone); 1-min load average {load:.1f}")
    return {"speed_scenario": name, "speed_runs": runs, "speed_steps": steps,
            "speed_wall_s": wall, "speed_cpu_s": cpu, "speed_threads": numba.get_num_threads(),
            "speed_ns_per_particle_step": cpu / (runs * steps * n) * 1e9,
            "load_average_1min": load}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="manoeuvring")
    ap.add_argument("--runs-ss", type=int, default=20, help="Stone Soup runs")
    ap.add_argument("--runs", type=int, default=1000, help="arrayproc RPF runs")
    ap.add_argument("--particles", type=int, default=5000)
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--speed-scenario", default="static",
                    help="scenario of the bearings+SPL throughput measurement (151 steps)")
    ap.add_argument("--speed-runs", type=int, default=0,
                    help="runs of the bearings+SPL throughput measurement (0: skip)")
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    out: dict = {}
    if args.speed_runs:
        out.update(speed_spl(args.speed_scenario, args.speed_runs, args.particles, args.seed))

    sc = get_scenario(args.scenario)
    tab = load_default_table()
    runs = max(args.runs, args.runs_ss)
    data = sc.simulate(runs, args.seed, tab)
    out.update({"scenario": sc.name, "particles": args.particles, "steps": data.times.size})

    f = RegularizedParticleFilter(RPFConfig(n_particles=args.particles, use_levels=False))
    f.run_many(data.times[:3], data.observer_pos[:3], data.bearings_deg[:1, :3])   # compile
    for threads in sorted({1, numba.get_num_threads()}):
        numba.set_num_threads(threads)
        c, t = time.process_time(), time.perf_counter()
        res = f.run_many(data.times, data.observer_pos, data.bearings_deg[:runs],
                         seeds=run_seeds(args.seed, runs, tag=9))
        el, cpu = time.perf_counter() - t, time.process_time() - c
        out[f"arrayproc_runs_per_s_{threads}thr"] = runs / el
        out[f"arrayproc_cpu_ms_per_run_{threads}thr"] = 1e3 * cpu / runs
        print(f"arrayproc RPF, {threads} thread(s): {runs} runs in {el:.2f} s "
              f"= {runs / el:.1f} runs/s; CPU {1e3 * cpu / runs:.2f} ms per run")
    err_ap = sc.position_error(res.est)

    ss_est = np.empty((args.runs_ss, data.times.size, 4))
    stonesoup_run(sc, data.times[:3], data.observer_pos, data.bearings_deg[0], 100, 0)  # warm
    c, t = time.process_time(), time.perf_counter()
    for r in range(args.runs_ss):
        ss_est[r] = stonesoup_run(sc, data.times, data.observer_pos, data.bearings_deg[r],
                                  args.particles, args.seed * 100003 + r)
    el, cpu = time.perf_counter() - t, time.process_time() - c
    out["stonesoup_runs_per_s"] = args.runs_ss / el
    out["stonesoup_cpu_ms_per_run"] = 1e3 * cpu / args.runs_ss
    out["load_average_1min_end"] = os.getloadavg()[0]
    print(f"Stone Soup PF: {args.runs_ss} runs in {el:.2f} s = {args.runs_ss / el:.3f} runs/s; "
          f"CPU {1e3 * cpu / args.runs_ss:.1f} ms per run")
    err_ss = sc.position_error(ss_est)
    n = args.runs_ss
    tmin = data.times / 60.0
    late = tmin >= 20.0
    rm_ap = np.sqrt(np.mean(err_ap[:n] ** 2, axis=0))
    rm_ss = np.sqrt(np.mean(err_ss**2, axis=0))
    out.update({
        "time_min": tmin.tolist(), "rmse_arrayproc_m": rm_ap.tolist(),
        "rmse_stonesoup_m": rm_ss.tolist(),
        "rmse_arrayproc_all_runs_m": np.sqrt(np.mean(err_ap**2, axis=0)).tolist(),
        "mean_rmse_20_30min_arrayproc_m": float(rm_ap[late].mean()),
        "mean_rmse_20_30min_stonesoup_m": float(rm_ss[late].mean()),
        "median_final_error_arrayproc_m": float(np.median(err_ap[:n, -1])),
        "median_final_error_stonesoup_m": float(np.median(err_ss[:, -1])),
    })
    for thr in sorted({1, numba.get_num_threads()}):
        out[f"speed_ratio_{thr}thr"] = out[f"arrayproc_runs_per_s_{thr}thr"] / out[
            "stonesoup_runs_per_s"]
        print(f"speed ratio (arrayproc {thr} thread(s) / Stone Soup): "
              f"{out[f'speed_ratio_{thr}thr']:.0f}x runs/s")
    out["cpu_ratio_1thr"] = out["stonesoup_cpu_ms_per_run"] / out[
        "arrayproc_cpu_ms_per_run_1thr"]
    print(f"CPU time per run, Stone Soup / arrayproc (1 thread): {out['cpu_ratio_1thr']:.0f}x")
    print(f"RMSE over the {n} common runs, mean over 20-30 min: arrayproc "
          f"{out['mean_rmse_20_30min_arrayproc_m']:.1f} m, Stone Soup "
          f"{out['mean_rmse_20_30min_stonesoup_m']:.1f} m; final "
          f"{rm_ap[-1]:.1f} m vs {rm_ss[-1]:.1f} m")
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
