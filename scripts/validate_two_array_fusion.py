"""Two bed arrays fused by cross-fix TMA (no speed prior): RMSE against the CRLB, mean NEES.

Usage: python scripts/validate_two_array_fusion.py [--runs 200] [--seed 0] [--compact-runs 20]
       python scripts/validate_two_array_fusion.py --cli-runs 50 [--seed 0]

``--cli-runs N``: N runs per CPA through ``arrayproc tma A.h5 B.h5 -c cross_fix`` (products
files written per run, each array's σ estimated) instead of the solver's Monte Carlo.
"""
from __future__ import annotations

import argparse
import tempfile

import numpy as np

from arrayproc.app.cli import main as cli_main
from arrayproc.evaluate.scenarios.two_array_fusion import run_fusion, run_fusion_cli


def _command(inputs: list[str], config: str, output: str) -> None:
    """``arrayproc tma INPUTS… -c CONFIG -o OUTPUT -q`` through the command line's main."""
    rc = cli_main(["tma", *inputs, "-c", config, "-o", output, "-q"])
    if rc != 0:
        raise SystemExit(f"arrayproc tma exited {rc}")


def cli_table(runs: int, baseline: float, sigma_deg: float, rng: np.random.Generator) -> None:
    """The ``--cli-runs`` table: RMSE against the CRLB, mean NEES (each run's own crlb)."""
    print("| CPA m | pos RMSE m | pos CRLB m | ratio | vel RMSE m/s | vel CRLB m/s | ratio "
          "| mean NEES | max abs z |")
    for d in (200.0, 500.0, 1000.0, 2000.0):
        with tempfile.TemporaryDirectory() as tmp:
            r = run_fusion_cli(d, baseline, sigma_deg, runs, rng, tmp, tma=_command)
        print(f"| {d:.0f} | {r['rmse_pos_m']:.1f} | {r['crlb_pos_m']:.1f} | "
              f"{r['ratio_pos']:.2f} | {r['rmse_vel_mps']:.3f} | {r['crlb_vel_mps']:.3f} | "
              f"{r['ratio_vel']:.2f} | {r['mean_nees']:.2f} | {r['max_abs_z']:.2f} |",
              flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--runs", type=int, default=200)
    ap.add_argument("--compact-runs", type=int, default=0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--baseline", type=float, default=500.0)
    ap.add_argument("--sigma-deg", type=float, default=2.0)
    ap.add_argument("--cli-runs", type=int, default=0)
    a = ap.parse_args()
    rng = np.random.default_rng(a.seed)
    if a.cli_runs:
        cli_table(a.cli_runs, a.baseline, a.sigma_deg, rng)
        return
    print("| CPA m | pos RMSE m | pos CRLB m | ratio | vel RMSE m/s | vel CRLB m/s | ratio "
          "| mean NEES |" + (" compact pos RMSE m | compact vel RMSE m/s |"
                              if a.compact_runs else ""))
    for d in (200.0, 500.0, 1000.0, 2000.0):
        r = run_fusion(d, a.baseline, a.sigma_deg, a.runs, rng)
        line = (f"| {d:.0f} | {r['rmse_pos_m']:.1f} | {r['crlb_pos_m']:.1f} | "
                f"{r['ratio_pos']:.2f} | {r['rmse_vel_mps']:.3f} | {r['crlb_vel_mps']:.3f} | "
                f"{r['ratio_vel']:.2f} | {r['mean_nees']:.2f} |")
        if a.compact_runs:
            c = run_fusion(d, a.baseline, a.sigma_deg, a.compact_runs, rng, compact=True)
            line += f" {c['compact_rmse_pos_m']:.1f} | {c['compact_rmse_vel_mps']:.3f} |"
        print(line, flush=True)


if __name__ == "__main__":
    main()
