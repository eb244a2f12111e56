"""Two static compact arrays, two vessels, one fused multi-target tracker
(``arrayproc track A.h5 B.h5 -c trackers/compact_fused.toml``): held share, position RMSE,
NEES and false tracks per vessel over several seeds (measurement-level azimuth rows,
:mod:`arrayproc.evaluate.scenarios.fused_tracker`).

Usage: python scripts/validate_fused_tracker.py [--seeds 10] [--seed 0] [--sigma-deg 1.0]
       [--pd 0.9] [--clutter 0.3]
"""
from __future__ import annotations

import argparse

from arrayproc.app.cli import main as cli_main
from arrayproc.data import data_path
from arrayproc.evaluate.scenarios.fused_tracker import run_fused_case


def _command(inputs: list[str], config: str, output: str) -> None:
    """``arrayproc track INPUTS… -c CONFIG -o OUTPUT -q`` through the command line's main."""
    rc = cli_main(["track", *inputs, "-c", config, "-o", output, "-q"])
    if rc != 0:
        raise SystemExit(f"arrayproc track exited {rc}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--seed", type=int, default=0, help="first seed")
    ap.add_argument("--sigma-deg", type=float, default=1.0)
    ap.add_argument("--pd", type=float, default=0.9)
    ap.add_argument("--clutter", type=float, default=0.3)
    a = ap.parse_args()
    cfg = str(data_path("trackers", "compact_fused.toml"))
    r = run_fused_case(list(range(a.seed, a.seed + a.seeds)), cfg, _command,
                       sigma_deg=a.sigma_deg, pd=a.pd, clutter=a.clutter)
    lo, hi = r["nees_band"]
    print(f"{r['seeds']} seeds, σ {a.sigma_deg:g} deg, P_D {a.pd:g}, clutter {a.clutter:g} "
          f"per scan; NEES 95 % band (2 dof, {r['seeds']} seeds) [{lo:.2f}, {hi:.2f}]")
    print("| vessel | held (mean) | held (min) | pos RMSE m | mean NEES |")
    for k, v in enumerate(r["vessels"]):
        print(f"| {k} | {v['held']:.3f} | {v['held_min']:.3f} | {v['rmse_m']:.1f} | "
              f"{v['nees']:.2f} |")
    print(f"false tracks per seed {r['false_per_seed']:.2f} (max {r['false_max']})")


if __name__ == "__main__":
    main()
