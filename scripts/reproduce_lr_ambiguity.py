#!/usr/bin/env python
"""Reproduce the L-R paper's section V (Das, Tiwari & Bhaumik): table I and figs. 4-7.

    python scripts/reproduce_lr_ambiguity.py --runs N [--json OUT] [--plot DIR] [--seed S]

For both cases (I: constant-velocity target and CV filters; II: target turning at 3°/min and
constant-turn filters) and each filter (EKF, UKF, CKF, GHF, SRF), runs N Monte Carlo runs with
the target side known (one filter on the true bearing) and with the side resolved (two filters
on the bearing pair, eqs. (9)-(13)), on the same noise. Prints a table beside the paper's and
writes, per case and filter, ``track_loss_pct_known_side``, ``track_loss_pct_resolved``,
``rmse_pos_final_m``, ``rmse_vel_final_mps``, ``true_side_pct``, ``relative_time`` (and more).
Geometry and priors: see :mod:`arrayproc.evaluate.montecarlo` (target starts at [5000, 800] m).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time

import numpy as np

from arrayproc.evaluate.montecarlo import LRScenario, pcrb_case1, run_case, warm_up
from arrayproc.track.filters import make_filter
from arrayproc.track.init import initial_state
from arrayproc.track.manage.lr import LRResolver
from arrayproc.track.models.bearing import Bearing
from arrayproc.track.models.motion import make_model
from arrayproc.track.state import Context

FILTERS = ["ekf", "ukf", "ckf", "ghf", "srf"]
# L-R paper table I: track loss % (known side, resolved) and relative execution time.
PAPER = {
    1: {"ekf": (5.68, 5.68, 1.0, 1.77), "ckf": (2.21, 2.21, 1.02, 2.07),
        "ukf": (1.42, 1.42, 1.10, 2.09), "ghf": (1.23, 1.23, 1.17, 2.29),
        "srf": (0.18, 0.22, 21.86, 43.47)},
    2: {"ekf": (12.25, 12.35, 0.88, 1.88), "ckf": (7.17, 7.17, 2.26, 4.10),
        "ukf": (5.90, 5.90, 2.05, 4.26), "ghf": (4.48, 4.49, 4.29, 8.56),
        "srf": (5.50, 5.57, 21.97, 44.17)},
}


def example_run(scn: LRScenario, name: str, params: dict, seed: int) -> dict[str, np.ndarray]:
    """One run through the filter objects and :class:`LRResolver` (fig. 4)."""
    g = scn.geometry()
    y1, y2, draws, rel = scn.measurements(1, seed)
    model = make_model(scn.model_name)
    meas = Bearing(sigma_deg=scn.sigma_deg)
    filt = make_filter(name, **params)
    prior = scn.prior
    n = model.ndim

    def fresh(z0):
        x0, P0 = initial_state(z0, g["own"][0], prior, n)
        # the same initial draw as the Monte Carlo kernel
        c = z0 + math.pi + draws[0, 2]
        x0[0], x0[1] = draws[0, 0] * math.sin(z0), draws[0, 0] * math.cos(z0)
        x0[2] = draws[0, 1] * math.sin(c) - g["own"][0, 2]
        x0[3] = draws[0, 1] * math.cos(c) - g["own"][0, 3]
        return filt.initialize(x0, P0)

    known = fresh(y1[0, 0])
    lr = LRResolver(filt, model, meas, [fresh(y1[0, 0]), fresh(y2[0, 0])])
    K = g["times"].size
    est_k = np.empty((K, n))
    est_r = np.empty((K, n))
    ghost = np.empty((K, n))
    w = np.empty(K)
    for k in range(K):
        if k > 0:
            T = g["times"][k] - g["times"][k - 1]
            ctx = Context(g["own"][k], g["own"][k - 1])
            known, _ = filt.update(filt.predict(known, model, T, ctx), y1[0, k], meas, ctx)
            lr.step(T, ctx, [y1[0, k], y2[0, k]])
        est_k[k] = known.x
        x, _, wk = lr.combine()
        est_r[k] = x
        ghost[k] = lr.states[1].x
        w[k] = wk[0]
    own = g["own"][:, :2]
    return {"own": own, "truth": rel[0, :, :2] + own, "known": est_k[:, :2] + own,
            "resolved": est_r[:, :2] + own, "ghost": ghost[:, :2] + own, "w": w,
            "times": g["times"]}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=500)
    ap.add_argument("--seed", type=int, default=2024)
    ap.add_argument("--json", help="write the numbers here")
    ap.add_argument("--plot", help="directory for the figures")
    ap.add_argument("--filters", default=",".join(FILTERS))
    ap.add_argument("--cases", default="1,2")
    ap.add_argument("--gh-order", type=int, default=3)
    ap.add_argument("--srf-likelihood", default="exact", choices=["exact", "paper"])
    ap.add_argument("--truth-noise", action="store_true",
                    help="drive the target with the model's process noise")
    ap.add_argument("--workers", type=int, default=None,
                    help="spread the runs over a local Dask cluster of N workers "
                         "(docs/scale-out.md: chunks of --chunk runs, each seeded from "
                         "SeedSequence(seed + case); numbers independent of N)")
    ap.add_argument("--scheduler", default=None, help="an existing Dask scheduler instead")
    ap.add_argument("--chunk", type=int, default=100, help="runs per Dask task")
    a = ap.parse_args(argv)
    filters = [f.strip() for f in a.filters.split(",") if f.strip()]
    cases = [int(c) for c in a.cases.split(",")]
    params = {"ghf": {"gh_order": a.gh_order}, "srf": {"likelihood": a.srf_likelihood}}

    t_all = time.perf_counter()
    warm_up(filters, params)
    t_compile = time.perf_counter() - t_all
    out: dict = {"meta": {
        "runs": a.runs, "seed": a.seed, "filters": filters, "cases": cases,
        "target_start_m": [5000.0, 800.0], "sigma_bearing_deg": 1.5, "dt_s": 60.0,
        "n_bearings": 31, "track_bound_m": 1000.0, "gh_order": a.gh_order,
        "srf_likelihood": a.srf_likelihood, "truth_noise": a.truth_noise,
        "ukf": "alpha=1, beta=0, kappa=3-n", "numba_threads": _threads(),
        "command": " ".join([os.path.basename(sys.argv[0])] + (argv or sys.argv[1:]))}}
    results: dict[int, dict[str, dict]] = {}
    curves: dict[int, dict] = {}
    t_ref = None
    client = None
    if a.workers or a.scheduler:
        from arrayproc.app.batch import start_client
        client, _cluster = start_client(a.workers, a.scheduler)
        client.run(warm_up, filters, params)  # JIT on every worker, outside the timings
    for case in cases:
        scn = LRScenario(case=case, truth_noise=a.truth_noise)
        if client is not None:
            results[case], curves[case] = _dask_case(client, a, case, filters, params)
            curves[case]["times"] = scn.times
            continue
        meas = scn.measurements(a.runs, a.seed + case)
        results[case] = {}
        curves[case] = {"rmse": {}, "bias": {}}
        for name in filters:
            p = params.get(name, {})
            known = run_case(scn, name, False, a.runs, a.seed, p, meas)
            res = run_case(scn, name, True, a.runs, a.seed, p, meas)
            if t_ref is None:
                t_ref = known.seconds
            results[case][name] = {
                "track_loss_pct_known_side": known.track_loss_pct,
                "track_loss_pct_resolved": res.track_loss_pct,
                "rmse_pos_final_m": float(res.rmse_pos[-1]),
                "rmse_vel_final_mps": float(res.rmse_vel[-1]),
                "rmse_pos_final_m_known_side": float(known.rmse_pos[-1]),
                "bias_norm_final_m": float(res.bias_norm[-1]),
                "true_side_pct": res.true_side_pct,
                "relative_time": res.seconds / t_ref,
                "relative_time_known_side": known.seconds / t_ref,
                "seconds_resolved": res.seconds, "seconds_known_side": known.seconds,
                "covariance_repaired_runs": known.n_repaired + res.n_repaired,
                "diverged_runs": known.n_diverged + res.n_diverged,
                "paper_track_loss_pct_known_side": PAPER[case][name][0],
                "paper_track_loss_pct_resolved": PAPER[case][name][1],
                "paper_relative_time_known_side": PAPER[case][name][2],
                "paper_relative_time_resolved": PAPER[case][name][3],
            }
            curves[case]["rmse"][name] = (res.rmse_pos, res.rmse_vel)
            curves[case]["bias"][name] = res.bias_norm
            del known, res
        curves[case]["times"] = scn.times
    wall = time.perf_counter() - t_all
    out["meta"]["wall_time_s"] = wall
    out["meta"]["compile_s"] = t_compile
    for case in cases:
        out[f"case_{'I' * case}"] = results[case]
        out[f"case_{'I' * case}_rmse_pos_m"] = {k: v[0].tolist() for k, v in
                                               curves[case]["rmse"].items()}
    if 1 in cases:
        out["case_I_crlb_pos_m"] = pcrb_case1(LRScenario(case=1)).tolist()
    _print_table(results, a.runs, wall)
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(out, fh, indent=1)
    if a.plot:
        _plots(a.plot, curves, params, a.seed)
    return 0


def _dask_case(client, a, case: int, filters: list[str], params: dict) -> tuple[dict, dict]:
    """One case's table rows and curves from Dask chunks
    (:func:`arrayproc.evaluate.distributed.lr_table`); times relative to the first filter's
    known-side time of the case."""
    from arrayproc.app.batch import worker_threads
    from arrayproc.evaluate.distributed import lr_table
    threads = worker_threads(a.workers) if a.workers else 1
    tab = lr_table(a.runs, a.seed, [case], filters, params, client=client, chunk=a.chunk,
                   truth_noise=a.truth_noise, threads=threads)[case]
    t_ref = tab[filters[0]]["seconds_known_side"]
    rows: dict = {}
    curves: dict = {"rmse": {}, "bias": {}}
    for name in filters:
        r = tab[name]
        rows[name] = {k: v for k, v in r.items() if not isinstance(v, np.ndarray)}
        rows[name].update({
            "relative_time": r["seconds_resolved"] / t_ref,
            "relative_time_known_side": r["seconds_known_side"] / t_ref,
            "paper_track_loss_pct_known_side": PAPER[case][name][0],
            "paper_track_loss_pct_resolved": PAPER[case][name][1],
            "paper_relative_time_known_side": PAPER[case][name][2],
            "paper_relative_time_resolved": PAPER[case][name][3]})
        curves["rmse"][name] = (r["rmse_pos_m"], r["rmse_vel_mps"])
        curves["bias"][name] = r["bias_norm_m"]
    return rows, curves


def _threads() -> int:
    import numba
    return int(numba.get_num_threads())


def _print_table(results, runs, wall) -> None:
    print(f"L-R paper table I reproduction, {runs} runs per entry (paper: 50,000)")
    hdr = (f"{'case':<5}{'filter':<7}{'loss% known':>12}{'(paper)':>9}{'loss% res.':>12}"
           f"{'(paper)':>9}{'true side%':>11}{'RMSE pos m':>11}{'RMSE vel':>9}{'rel.time':>9}"
           f"{'(paper)':>9}")
    print(hdr)
    for case, rs in results.items():
        for name, r in rs.items():
            print(f"{'I' * case:<5}{name.upper():<7}{r['track_loss_pct_known_side']:>12.2f}"
                  f"{r['paper_track_loss_pct_known_side']:>9.2f}"
                  f"{r['track_loss_pct_resolved']:>12.2f}"
                  f"{r['paper_track_loss_pct_resolved']:>9.2f}{r['true_side_pct']:>11.2f}"
                  f"{r['rmse_pos_final_m']:>11.0f}{r['rmse_vel_final_mps']:>9.2f}"
                  f"{r['relative_time']:>9.2f}{r['paper_relative_time_resolved']:>9.2f}")
    print(f"wall time {wall:.1f} s (including JIT warm-up)")


def _plots(d: str, curves, params, seed) -> None:
    from arrayproc.plots.track import plot_bias, plot_lr_example, plot_rmse
    os.makedirs(d, exist_ok=True)
    for case, c in curves.items():
        roman = "I" * case
        bound = pcrb_case1(LRScenario(case=1)) if case == 1 else None
        plot_rmse(c["times"], c["rmse"], os.path.join(d, f"lr_rmse_case{case}.png"), bound,
                  f"Case {roman}: RMSE with L-R resolved (runs not lost)")
        plot_bias(c["times"], c["bias"], os.path.join(d, f"lr_bias_case{case}.png"),
                  f"Case {roman}: bias norm with L-R resolved")
        scn = LRScenario(case=case)
        ex = example_run(scn, "ghf", params.get("ghf", {}), seed)
        plot_lr_example(ex["own"], ex["truth"], ex["known"], ex["resolved"], ex["ghost"],
                        ex["w"], ex["times"], os.path.join(d, f"lr_tracks_case{case}.png"),
                        title=f"Case {roman}: GHF, one run (seed {seed})")


if __name__ == "__main__":
    raise SystemExit(main())
