#!/usr/bin/env python
"""Reproduce the L-R paper's section V (Das, Tiwari & Bhaumik): table I and figs. 4-7.

    python scripts/reproduce_lr_ambiguity.py --runs N [--json OUT] [--plot DIR] [--seed S]

For both cases (I: constant-velocity target and CV filters; II: target turning at 3°/min and
constant-turn filters) and each filter (EKF, UKF, CKF, GHF, SRF), runs N Monte Carlo runs with
the target side known (one filter on the true bearing) and with the side resolved (two filters
on the bearing pair, eqs. (9)-(13)), on the same noise. Prints a table beside the paper's and
writes, per case and filter, ``track_loss_pct_known_side``, ``track_loss_pct_resolved``,
``rmse_pos_final_m``, ``rmse_vel_final_mps``, ``true_side_pct``, ``relative_time`` (and more).
Table and runs: :mod:`arrayproc.evaluate.scenarios.lr_paper`; geometry and priors:
:mod:`arrayproc.evaluate.montecarlo` (target starts at [5000, 800] m).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

from arrayproc.evaluate.scenarios.lr_paper import (
    FILTERS,
    LRScenario,
    example_run,
    pcrb_case1,
    table_case,
    table_case_dask,
    warm_up,
)


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
            from arrayproc.app.batch import worker_threads
            threads = worker_threads(a.workers) if a.workers else 1
            results[case], curves[case] = table_case_dask(
                client, case, filters, a.runs, a.seed, params, a.chunk, a.truth_noise, threads)
            curves[case]["times"] = scn.times
            continue
        results[case], curves[case], t_ref = table_case(scn, filters, a.runs, a.seed, params,
                                                        t_ref)
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
