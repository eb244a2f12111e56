"""Two bed arrays fused by cross-fix TMA (no speed prior): RMSE against the CRLB, mean NEES.

Usage: python scripts/validate_two_array_fusion.py [--runs 200] [--seed 0] [--compact-runs 20]
"""
from __future__ import annotations

import argparse

import numpy as np

from arrayproc.evaluate.scenarios.two_array_fusion import run_fusion


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--runs", type=int, default=200)
    ap.add_argument("--compact-runs", type=int, default=0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--baseline", type=float, default=500.0)
    ap.add_argument("--sigma-deg", type=float, default=2.0)
    a = ap.parse_args()
    rng = np.random.default_rng(a.seed)
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
