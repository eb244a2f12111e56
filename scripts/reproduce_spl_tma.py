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
import time
from pathlib import Path

import numba
import numpy as np

from arrayproc.acoustics.tl import load_default_table
from arrayproc.evaluate.scenarios import get_scenario
from arrayproc.plots.rmse import plot_rmse_curves, plot_scenario_geometry
from arrayproc.track.crlb import position_rmse_bound
from arrayproc.track.filters.particle import RegularizedParticleFilter, RPFConfig, run_seeds

#: Published values: (time_min, BOT m, BOT+SPL m); None where the paper gives no number.
PAPER = {
    "manoeuvring": {"min near 24 min": (24.0, 155.0, 85.0), "final (30 min)": (30.0, 228.58,
                                                                                146.17)},
    "static": {"36 min": (36.0, 2857.0, 344.0), "63 min": (63.0, 4338.0, 203.0),
               "final (150 min)": (150.0, 13657.0, 1532.0)},
    "parallel": {},
}


def parallel_grid_posterior(sc, data, tab, n_runs: int) -> dict:
    """Parallel scenario: the exact posterior on the constant-bearing family (the BOT
    ambiguity: relative position r(t) = (r0 + ṙ t)·u, target velocity v_obs + ṙ u, zero
    process noise), from the paper's prior and the level likelihood with the filter's σ_l,
    on a grid of (r0, ṙ). Returns the RMSE of its posterior-mean range at each time — what an
    ideal filter could reach without regularization noise (a diagnostic, not the paper's
    algorithm)."""
    sl = sc.source_level
    t = data.times
    u = data.truth[0, :2] - data.observer_pos[0]
    u = u / np.hypot(*u)
    v_obs = sc.observer.state(t)[1][0]
    c0 = np.arctan2(*u) + np.pi
    r0 = np.arange(1000.0, 40001.0, 250.0)
    rdot = np.arange(-3.0, 10.0, 0.05)
    true_r = np.hypot(*(data.truth[:, :2] - data.observer_pos).T)
    sq = np.zeros(t.size)
    for run in range(n_runs):
        lp = np.full((r0.size, rdot.size), -np.inf)
        for j, rd in enumerate(rdot):
            v = v_obs + rd * u
            spd, crs = np.hypot(*v), np.arctan2(v[0], v[1])
            r = r0[:, None] + rd * t[None, :]
            pred = sl(spd) - tab(np.maximum(r, 1.0), sc.target_depth_m, sc.observer_depth_m)
            ll = -np.sum((data.levels_db[run] - pred) ** 2, axis=1) / (
                2 * sc.sigma_level_filter_db**2)
            prior = (-(r0 - sc.range_prior_m[0]) ** 2 / (2 * sc.range_prior_m[1] ** 2)
                     - (spd - sc.speed_prior[0]) ** 2 / (2 * sc.speed_prior[1] ** 2)
                     - np.angle(np.exp(1j * (crs - c0))) ** 2 / (2 * sc.course_std_rad**2))
            lp[:, j] = np.where(r.min(axis=1) > 100.0, ll + prior, -np.inf)
        p = np.exp(lp - lp.max())
        p /= p.sum()
        for k in range(t.size):
            rk = r0[:, None] + rdot[None, :] * t[k]
            sq[k] += ((p * rk).sum() - true_r[k]) ** 2
    return {"grid_runs": n_runs, "grid_rmse_range_m": np.sqrt(sq / n_runs).tolist()}


def rmse(err: np.ndarray) -> np.ndarray:
    return np.sqrt(np.mean(err**2, axis=0))


_CLIENT: list = []


def _spread_rpf(args, cfg, data, use: bool, seeds: np.ndarray):
    """The runs in slices of ``--chunk`` on Dask (:func:`arrayproc.evaluate.distributed.
    rpf_slice`); each run keeps its own seed, so the result equals one process's."""
    from types import SimpleNamespace

    from arrayproc.app.batch import start_client
    from arrayproc.evaluate.distributed import rpf_slice, spread_slices
    if not _CLIENT:
        _CLIENT.extend(start_client(args.workers, args.scheduler))
    parts = spread_slices(rpf_slice, args.runs, _CLIENT[0], args.chunk, config=cfg,
                          times=data.times, observer_pos=data.observer_pos,
                          bearings_deg=data.bearings_deg,
                          levels_db=data.levels_db if use else None, seeds=seeds)
    return SimpleNamespace(est=np.concatenate([p[0] for p in parts]),
                           resampled=np.concatenate([p[1] for p in parts]))


def main(argv: list[str] | None = None) -> dict:
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
                         "then include the cluster's start and the workers' JIT")
    ap.add_argument("--scheduler", default=None, help="an existing Dask scheduler instead")
    ap.add_argument("--chunk", type=int, default=10, help="runs per Dask task")
    args = ap.parse_args(argv)
    if args.grid_check and args.truth_sigma_a > 0:
        ap.error("--grid-check needs the deterministic truth (--truth-sigma-a 0)")

    sc = get_scenario(args.scenario)
    tab = load_default_table(args.tl)
    data = sc.simulate(args.runs, args.seed, tab, truth_sigma_a=args.truth_sigma_a)
    out: dict = {"scenario": sc.name, "runs": args.runs, "particles": args.particles,
                 "seed": args.seed, "resampling": args.resampling,
                 "bandwidth_scale": args.bandwidth_scale,
                 "sigma_a": 1.5e-3 if args.sigma_a is None else args.sigma_a, "tl": args.tl,
                 "course_prior": args.course_prior, "max_speed_kn": args.max_speed_kn,
                 "truth_sigma_a": args.truth_sigma_a,
                 "threads": numba.get_num_threads(),
                 "tl_table": str(tab.attrs.get("description", ""))}
    rm = {}
    for label, use in (("bot", False), ("spl", True)):
        cfg = RPFConfig(n_particles=args.particles, use_levels=use, tl_table=tab,
                        resampling=args.resampling, bandwidth_scale=args.bandwidth_scale,
                        sigma_a=1.5e-3 if args.sigma_a is None else args.sigma_a,
                        sigma_bearing_deg=sc.sigma_bearing_deg,
                        sigma_level_db=sc.sigma_level_filter_db,
                        course_prior=args.course_prior, max_speed_kn=args.max_speed_kn)
        f = RegularizedParticleFilter(cfg)
        f.run_many(data.times[:3], data.observer_pos[:3], data.bearings_deg[:1, :3],
                   data.levels_db[:1, :3] if use else None)          # compile outside timing
        t0 = time.perf_counter()
        seeds = run_seeds(args.seed, args.runs, tag=1 + int(use))
        if args.workers or args.scheduler:
            res = _spread_rpf(args, cfg, data, use, seeds)
        else:
            res = f.run_many(data.times, data.observer_pos, data.bearings_deg,
                             data.levels_db if use else None, seeds=seeds)
        out[f"wall_s_{label}"] = time.perf_counter() - t0
        err = sc.position_error(res.est, data.truth)
        rm[label] = rmse(err)
        out[f"resampling_fraction_{label}"] = float(res.resampled.mean())
        out[f"median_final_error_{label}_m"] = float(np.median(err[:, -1]))
    crlb = position_rmse_bound(sc.crlb())
    tmin = data.times / 60.0
    out.update({"time_min": tmin.tolist(), "rmse_bot_m": rm["bot"].tolist(),
                "rmse_spl_m": rm["spl"].tolist(),
                "crlb_bot_m": [None if not np.isfinite(c) else float(c) for c in crlb]})

    # comparison table with the paper
    rows = []
    for what, (t, pb, ps) in PAPER[sc.name].items():
        i = int(np.argmin(np.abs(tmin - t)))
        rows.append({"what": what, "time_min": t, "paper_bot_m": pb, "ours_bot_m": rm["bot"][i],
                     "paper_spl_m": ps, "ours_spl_m": rm["spl"][i]})
    if sc.name == "manoeuvring":
        after = tmin >= 17.0
        for label in ("bot", "spl"):
            j = int(np.argmin(np.where(after, rm[label], np.inf)))
            out[f"min_rmse_{label}_m"] = float(rm[label][j])
            out[f"min_rmse_{label}_time_min"] = float(tmin[j])
    if sc.name == "static":
        for label in ("bot", "spl"):
            j = int(np.argmin(rm[label]))
            out[f"min_rmse_{label}_m"] = float(rm[label][j])
            out[f"min_rmse_{label}_time_min"] = float(tmin[j])
        rows.append({"what": "CRLB at 150 min (paper: 313.88 % above RMSE+SPL)",
                     "time_min": 150.0, "paper_bot_m": 1532.0 * 4.1388,
                     "ours_bot_m": float(crlb[-1]), "paper_spl_m": None, "ours_spl_m": None})
    if sc.name == "parallel":
        below = np.where(rm["spl"] < crlb)[0]
        out["spl_below_crlb_from_min"] = float(tmin[below[0]]) if below.size else None
        out["final_ratio_bot_over_spl"] = float(rm["bot"][-1] / rm["spl"][-1])
        rows.append({"what": "final BOT/SPL ratio (paper 5.77)", "time_min": 150.0,
                     "paper_bot_m": 5.7743, "ours_bot_m": out["final_ratio_bot_over_spl"],
                     "paper_spl_m": None, "ours_spl_m": None})
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
    return out


if __name__ == "__main__":
    sys.exit(0 if main() else 1)
