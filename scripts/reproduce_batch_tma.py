#!/usr/bin/env python
"""Reproduce thesis fig. 3.19: BO-TMA and TD-TMA position error against the CRLB.

Scenario of fig. 3.18 (:mod:`arrayproc.track.batch.scenarios`): source initial position
(2000 m, 1000 m), 128 hydrophones spaced 0.36 m, σ_τ = 1e-4 s for the delays and the
bearing precision σ_θ = 0.0306° the thesis takes from appendix C.1. Each run draws new
Gaussian errors and solves both estimators (differential evolution + least-squares polish);
the position-error standard deviation is compared with the CRLB (thesis eq. (3.53)).
Targets: TD-TMA within 15 % of its CRLB, BO-TMA within 30 %.

Usage:
  python scripts/reproduce_batch_tma.py --runs N [--seed 1] [--json OUT] [--plot DIR]
      [--workers N | --scheduler ADDRESS] [--chunk 10]

Without --workers/--scheduler the runs go one after the other here (the numbers of
docs/validation/batch_tma.md); with them, chunks of --chunk runs on Dask, each chunk seeded
from SeedSequence(seed): the same numbers on any number of workers (docs/scale-out.md).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from arrayproc.evaluate.scenarios.thesis_tma import C, fig_3_19
from arrayproc.track.batch import scenarios as S


def run(runs: int, seed: int, client=None, chunk: int = 10) -> dict:
    """Fig. 3.19's Monte Carlo (:func:`arrayproc.evaluate.scenarios.thesis_tma.fig_3_19`),
    logging progress every 10 runs."""
    def log(done: int) -> None:
        if done % 10 == 0:
            print(f"  run {done}/{runs}", file=sys.stderr, flush=True)

    return fig_3_19(runs, seed, client, chunk, log)


def plot(res: dict, outdir: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    outdir.mkdir(parents=True, exist_ok=True)
    tr = S.turn_track()
    x = S.FIG_3_18_SOURCE
    src = S.source_positions(x, tr.time)
    fig, ax = plt.subplots(figsize=(5, 5))
    ax.plot(tr.position[:, 0], tr.position[:, 1], "k-", label="ownship")
    ax.plot(src[:, 0], src[:, 1], "r-", label="source")
    ax.plot(tr.position[0, 0], tr.position[0, 1], "ko")
    ax.plot(src[0, 0], src[0, 1], "ro")
    ax.set_xlabel("x east (m)")
    ax.set_ylabel("y north (m)")
    ax.set_aspect("equal")
    ax.legend()
    ax.set_title("Fig. 3.18 scenario (our reading); dots: start")
    fig.tight_layout()
    fig.savefig(outdir / "fig3_18_scenario.png", dpi=120)
    plt.close(fig)

    fig, axes = plt.subplots(2, 2, figsize=(9, 7))
    for row, m in enumerate(("bearings", "delays")):
        e = np.array(res[m]["errors"])
        for col, (k, lab) in enumerate(((0, "x"), (1, "y"))):
            ax = axes[row, col]
            s = res[m][f"crlb_{lab}_m"]
            ax.hist(e[:, k], bins=20, density=True, color="k", alpha=0.6,
                    label=f"{res['runs']} runs, std {res[m][f'std_{lab}_m']:.2f} m")
            g = np.linspace(-4 * s, 4 * s, 200)
            ax.plot(g, np.exp(-0.5 * (g / s) ** 2) / (s * np.sqrt(2 * np.pi)), "r-",
                    label=f"CRLB σ {s:.2f} m")
            ax.set_xlabel(f"initial {lab} error (m)")
            ax.set_ylabel("density (1/m)")
            ax.set_title(f"{'BO-TMA' if m == 'bearings' else 'TD-TMA'}: {lab}")
            ax.legend(fontsize=8)
    fig.suptitle("Thesis fig. 3.19: position error distribution vs CRLB")
    fig.tight_layout()
    fig.savefig(outdir / "fig3_19_position_errors.png", dpi=120)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=100)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--json", default=None, help="write the numbers to this JSON file")
    ap.add_argument("--plot", default=None, help="directory for the PNG figures")
    ap.add_argument("--workers", type=int, default=None,
                    help="spread the runs over a local Dask cluster of N workers "
                         "(docs/scale-out.md: chunks of --chunk runs, each seeded from "
                         "SeedSequence(seed); numbers independent of N)")
    ap.add_argument("--scheduler", default=None, help="an existing Dask scheduler instead")
    ap.add_argument("--chunk", type=int, default=10, help="runs per Dask task")
    a = ap.parse_args(argv)
    if a.runs < 2 or a.chunk < 1 or (a.workers is not None and a.workers < 1):
        print("reproduce_batch_tma: --runs must be >= 2, --chunk and --workers >= 1",
              file=sys.stderr)
        return 2
    client = cluster = None
    if a.workers or a.scheduler:
        from arrayproc.app.batch import start_client
        client, cluster = start_client(a.workers, a.scheduler)
    t = time.perf_counter()
    try:
        res = run(a.runs, a.seed, client, a.chunk)
    finally:
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
    res["wall_s"] = time.perf_counter() - t
    for m in ("bearings", "delays"):
        r = res[m]
        print(f"{m:9s}: position std {r['position_std_m']:.3f} m, CRLB "
              f"{r['position_crlb_m']:.3f} m, ratio {r['ratio']:.3f} ({r['target']}: "
              f"{'met' if r['met'] else 'NOT met'}); x {r['std_x_m']:.3f}/{r['crlb_x_m']:.3f}"
              f" m, y {r['std_y_m']:.3f}/{r['crlb_y_m']:.3f} m; "
              f"{r['seconds_per_solution']:.2f} s per solution")
    print(f"C.6 sigma_theta at broadside for sigma_tau = 1e-4 s, c = {C} m/s: "
          f"{res['scenario']['c6_sigma_theta_broadside_deg']:.4f} deg (thesis uses 0.0306)")
    if a.json:
        Path(a.json).write_text(json.dumps(res, indent=1))
    if a.plot:
        plot(res, Path(a.plot))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
