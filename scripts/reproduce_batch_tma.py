#!/usr/bin/env python
"""Reproduce thesis fig. 3.19: BO-TMA and TD-TMA position error against the CRLB.

Scenario of fig. 3.18 (:mod:`arrayproc.track.batch.scenarios`): source initial position
(2000 m, 1000 m), 128 hydrophones spaced 0.36 m, σ_τ = 1e-4 s for the delays and the
bearing precision σ_θ = 0.0306° the thesis takes from appendix C.1. Each run draws new
Gaussian errors and solves both estimators (differential evolution + least-squares polish);
the position-error standard deviation is compared with the CRLB (thesis eq. (3.53)).
Targets (issue 15): TD-TMA within 15 % of its CRLB, BO-TMA within 30 %.

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

from arrayproc.track.batch import scenarios as S
from arrayproc.track.batch.fim import bo_fim, crlb_from_fim, td_fim

SIGMA_TAU = 1e-4                    # s (thesis 3.3.3.1)
SIGMA_THETA = np.deg2rad(0.0306)    # rad (thesis 3.3.3.1, from app. C.1)
N_H, DX, C = 128, 0.36, 1500.0


def c6_sigma_theta(theta_deg: float = 90.0) -> float:
    """σ_θ (deg) of thesis eq. (C.6) for the array and σ_τ above, at cone angle θ."""
    j = (DX * np.sin(np.deg2rad(theta_deg)) / (SIGMA_TAU * C)) ** 2 * N_H * (N_H - 1) \
        * (2 * N_H - 1) / 6
    return float(np.rad2deg(1 / np.sqrt(j)))


def run(runs: int, seed: int, client=None, chunk: int = 10) -> dict:
    """Fig. 3.19's Monte Carlo: here, run i seeded as before (one generator for every run's
    errors, solvers seeded ``seed * 100003 + i``); on a Dask client, chunks of ``chunk`` runs,
    chunk k drawing from ``SeedSequence(seed).spawn(n_chunks)[k]``
    (:func:`arrayproc.evaluate.distributed.spread`): the same numbers on any number of
    workers, not the same as here."""
    from arrayproc.evaluate.distributed import spread, tma_chunk
    tr = S.turn_track()
    el = S.line_elements(tr, N_H, DX)
    x = S.FIG_3_18_SOURCE
    crlb_b = crlb_from_fim(bo_fim(x, tr.time, tr.position, SIGMA_THETA))[0]
    crlb_d = crlb_from_fim(td_fim(x, tr.time, el, 0, C, SIGMA_TAU))[0]
    scenario = dict(times=tr.time, observer_pos=tr.position, elements_xy=el,
                    heading_rad=tr.heading, state=x, sigma_theta_rad=SIGMA_THETA,
                    sigma_tau_s=SIGMA_TAU, sound_speed=C)

    def log(done: int) -> None:
        if done % 10 == 0:
            print(f"  run {done}/{runs}", file=sys.stderr, flush=True)

    if client is None:
        parts = [tma_chunk(runs, seed, **scenario, log=log,
                           seeds=[seed * 100003 + i for i in range(runs)])]
    else:
        parts = spread(tma_chunk, runs, seed, client, chunk, **scenario)
    err = {m: np.concatenate([p[m] for p in parts]) for m in ("bearings", "delays")}
    t_solve = {m: float(sum(p[f"seconds_{m}"] for p in parts)) for m in ("bearings", "delays")}
    out: dict = {"runs": runs, "seed": seed,
                 "seeding": "one generator" if client is None else f"chunks of {chunk}",
                 "scenario": {
        "source_state": x.tolist(), "n_hydrophones": N_H, "spacing_m": DX,
        "sigma_tau_s": SIGMA_TAU, "sigma_theta_deg": float(np.rad2deg(SIGMA_THETA)),
        "c6_sigma_theta_broadside_deg": c6_sigma_theta(), "snapshots": int(tr.time.size),
        "ownship": "3 m/s, course 0 deg for 300 s then 315 deg for 300 s",
        "source": "3 m/s course 0 deg from (2000, 1000) m"}}
    targets = {"bearings": 0.30, "delays": 0.15}
    for m, crlb in (("bearings", crlb_b), ("delays", crlb_d)):
        e = np.array(err[m])
        std_xy = e[:, :2].std(0, ddof=1)
        bound_xy = np.sqrt(np.diag(crlb)[:2])
        pos_std = float(np.sqrt(np.sum(std_xy**2)))
        pos_bound = float(np.sqrt(np.trace(crlb[:2, :2])))
        ratio = pos_std / pos_bound
        out[m] = {"std_x_m": float(std_xy[0]), "std_y_m": float(std_xy[1]),
                  "crlb_x_m": float(bound_xy[0]), "crlb_y_m": float(bound_xy[1]),
                  "position_std_m": pos_std, "position_crlb_m": pos_bound,
                  "ratio": ratio, "bias_x_m": float(e[:, 0].mean()),
                  "bias_y_m": float(e[:, 1].mean()),
                  "std_vx_mps": float(e[:, 2].std(ddof=1)),
                  "std_vy_mps": float(e[:, 3].std(ddof=1)),
                  "crlb_vx_mps": float(np.sqrt(crlb[2, 2])),
                  "crlb_vy_mps": float(np.sqrt(crlb[3, 3])),
                  "target": f"within {targets[m]:.0%} of the CRLB",
                  "met": bool(abs(ratio - 1) <= targets[m]),
                  "seconds_per_solution": t_solve[m] / runs,
                  "errors": e.tolist()}
    return out


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
