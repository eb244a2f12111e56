#!/usr/bin/env python
"""Reproduce the RMSE curves of Iglésis & de Montella (2024), section 5 (figs. 3, 5, 7, table 1).

For each Monte Carlo run the same simulated bearings and levels are given to the RPF twice:
bearings-only (BOT) and bearings + SPL. Prints the paper's numbers next to ours.

Usage:
  python scripts/reproduce_spl_tma.py --scenario manoeuvring|parallel|static --runs N
         [--particles 5000] [--seed 1] [--resampling systematic|multinomial]
         [--course-prior uniform|normal] [--max-speed-kn V] [--json OUT] [--plot DIR]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numba
import numpy as np

from arrayproc.acoustics.tl import load_default_table
from arrayproc.evaluate.scenarios.spl_paper import (
    PAPER,
    compare_with_paper,
    get_scenario,
    parallel_grid_posterior,
    rpf_monte_carlo,
)
from arrayproc.plots.rmse import plot_rmse_curves, plot_scenario_geometry
from arrayproc.track.crlb import position_rmse_bound


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", required=True, choices=["manoeuvring", "parallel", "static"])
    ap.add_argument("--runs", type=int, default=100)
    ap.add_argument("--particles", type=int, default=5000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--resampling", default="systematic", choices=["systematic", "multinomial"])
    ap.add_argument("--bandwidth-scale", type=float, default=1.0,
                    help="multiplier of the MISE-optimal bandwidth (paper: 1)")
    ap.add_argument("--sigma-a", type=float, default=None,
                    help="filter process noise, m/s^2 (paper: 1.5e-3)")
    ap.add_argument("--course-prior", default="normal", choices=["normal", "uniform"],
                    help="prior course about z0 + pi with std pi/sqrt(12): normal (Ristic et "
                         "al. 2003 ch. 6.4.1.1, default) or uniform over a half circle")
    ap.add_argument("--max-speed-kn", type=float, default=0.0,
                    help="zero weight for particles faster than this (not in the paper; "
                         "0: off)")
    ap.add_argument("--truth-sigma-a", type=float, default=0.0,
                    help="drive each run's true track by white accelerations of this std "
                         "(m/s^2; the paper's target keeps a steady course: 0)")
    ap.add_argument("--tl", default="munk_bellhopcxx_incoherent",
                    help="bundled TL table in data/tl (without .h5)")
    ap.add_argument("--grid-check", type=int, default=0,
                    help="parallel scenario: exact constant-bearing posterior on a grid for "
                         "this many runs (diagnostic)")
    ap.add_argument("--json", default=None)
    ap.add_argument("--plot", default=None, help="directory for the PNG figures")
    ap.add_argument("--workers", type=int, default=None,
                    help="spread the runs over a local Dask cluster of N workers (per-run seeds: "
                         "the same numbers as one process; docs/scale-out.md); the wall times "
                         "then include the workers' JIT (not the cluster's start)")
    ap.add_argument("--scheduler", default=None, help="an existing Dask scheduler instead")
    ap.add_argument("--chunk", type=int, default=10, help="runs per Dask task")
    args = ap.parse_args(argv)
    if args.grid_check and args.truth_sigma_a > 0:
        ap.error("--grid-check needs the deterministic truth (--truth-sigma-a 0)")
    return args


def plot(args: argparse.Namespace, sc, data, tmin: np.ndarray, rm: dict, crlb: np.ndarray,
         out: dict) -> None:
    """RMSE curves against the CRLB and the paper's points, and the scenario geometry."""
    d = Path(args.plot)
    d.mkdir(parents=True, exist_ok=True)
    tag = sc.name
    notes = []
    if args.bandwidth_scale != 1.0 or args.sigma_a is not None:
        tag += f"_h{args.bandwidth_scale:g}_sa{out['sigma_a']:g}"
        notes += [f"h × {args.bandwidth_scale:g}", f"σ_a = {out['sigma_a']:g} m/s²"]
    if args.course_prior != "normal":
        tag += f"_course_{args.course_prior}"
        notes.append(f"{args.course_prior} course prior")
    if args.max_speed_kn > 0:
        tag += f"_vmax{args.max_speed_kn:g}kn"
        notes.append(f"speed ≤ {args.max_speed_kn:g} kn")
    if args.truth_sigma_a > 0:
        tag += f"_truthsa{args.truth_sigma_a:g}"
        notes.append(f"truth σ_a = {args.truth_sigma_a:g} m/s²")
    pts = {}
    if PAPER[sc.name]:
        ts = [v[0] for v in PAPER[sc.name].values()]
        pts = {"paper BOT": (ts, [v[1] for v in PAPER[sc.name].values()]),
               "paper bearings + SPL": (ts, [v[2] for v in PAPER[sc.name].values()])}
    plot_rmse_curves(tmin, {"BOT (RPF)": rm["bot"], "bearings + SPL (RPF)": rm["spl"]},
                     str(d / f"spl_tma_rmse_{tag}.png"), crlb=crlb,
                     title=f"{sc.name} observer, {args.runs} runs, N = {args.particles}"
                     + ("" if tag == sc.name else " (" + ", ".join(notes) + ")"),
                     paper_points=pts)
    plot_scenario_geometry(data.truth if data.truth.ndim == 2 else data.truth[0],
                           data.observer_pos,
                           str(d / f"spl_tma_geometry_{sc.name}.png"),
                           title=f"{sc.name} scenario")


def main(argv: list[str] | None = None) -> dict:
    args = parse_args(argv)
    sc = get_scenario(args.scenario)
    tab = load_default_table(args.tl)
    data = sc.simulate(args.runs, args.seed, tab, truth_sigma_a=args.truth_sigma_a)
    sigma_a = 1.5e-3 if args.sigma_a is None else args.sigma_a
    out: dict = {"scenario": sc.name, "runs": args.runs, "particles": args.particles,
                 "seed": args.seed, "resampling": args.resampling,
                 "bandwidth_scale": args.bandwidth_scale,
                 "sigma_a": sigma_a, "tl": args.tl,
                 "course_prior": args.course_prior, "max_speed_kn": args.max_speed_kn,
                 "truth_sigma_a": args.truth_sigma_a,
                 "threads": numba.get_num_threads(),
                 "tl_table": str(tab.attrs.get("description", ""))}
    client = cluster = None
    if args.workers or args.scheduler:
        from arrayproc.app.batch import start_client
        client, cluster = start_client(args.workers, args.scheduler)
    try:
        mc = rpf_monte_carlo(sc, data, tab, args.particles, args.seed, args.resampling,
                             args.bandwidth_scale, sigma_a, args.course_prior,
                             args.max_speed_kn, client, args.chunk)
    finally:
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
    rm = {label: mc.pop(f"rmse_{label}") for label in ("bot", "spl")}
    for label in ("bot", "spl"):
        for key in (f"wall_s_{label}", f"resampling_fraction_{label}",
                    f"median_final_error_{label}_m"):
            out[key] = mc[key]
    crlb = position_rmse_bound(sc.crlb())
    tmin = data.times / 60.0
    out.update({"time_min": tmin.tolist(), "rmse_bot_m": rm["bot"].tolist(),
                "rmse_spl_m": rm["spl"].tolist(),
                "crlb_bot_m": [None if not np.isfinite(c) else float(c) for c in crlb]})
    rows, extra = compare_with_paper(sc.name, tmin, rm, crlb)
    out.update(extra)
    out["paper_comparison"] = rows
    if args.grid_check and sc.name == "parallel":
        out.update(parallel_grid_posterior(sc, data, tab, min(args.grid_check, args.runs)))
        g = out["grid_rmse_range_m"]
        print(f"exact constant-bearing posterior ({out['grid_runs']} runs): range RMSE "
              f"{g[60]:.0f} m at 60 min, {g[-1]:.0f} m at 150 min")

    print(f"{sc.name}: {args.runs} runs, N = {args.particles}, {numba.get_num_threads()} threads; "
          f"wall BOT {out['wall_s_bot']:.1f} s, SPL {out['wall_s_spl']:.1f} s")
    print(f"{'':44s} {'paper BOT':>10s} {'ours BOT':>10s} {'paper SPL':>10s} {'ours SPL':>10s}")
    for r in rows:
        def f(v):
            return f"{v:10.1f}" if isinstance(v, float | int) else f"{'':>10s}"
        print(f"{r['what']:44s} {f(r['paper_bot_m'])} {f(r['ours_bot_m'])} "
              f"{f(r['paper_spl_m'])} {f(r['ours_spl_m'])}")
    for key in ("min_rmse_bot_m", "min_rmse_bot_time_min", "min_rmse_spl_m",
                "min_rmse_spl_time_min", "spl_below_crlb_from_min"):
        if key in out:
            print(f"  {key} = {out[key]}")

    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(json.dumps(out, indent=1))
    if args.plot:
        plot(args, sc, data, tmin, rm, crlb, out)
    return out


if __name__ == "__main__":
    sys.exit(0 if main() else 1)
