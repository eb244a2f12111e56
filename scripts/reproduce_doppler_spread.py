"""Thesis fig. 4.4: matched-filter loss of BPSK and HFM echoes under the time distortion of
eq. (4.6), for α = 0 … 1 ms, each pulse distorted directly and through the simulator
(:mod:`arrayproc.evaluate.scenarios.thesis_doppler_spread`). Prints the loss as 20 log10 of
the peak ratio (the peak of |χ|, an amplitude).

    .venv/bin/python scripts/reproduce_doppler_spread.py [--alphas 0,0.25,0.5,0.75,1]
        [--json OUT] [--plot OUT.png]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from arrayproc.evaluate.scenarios.thesis_doppler_spread import fig_4_4


def log(row: dict) -> None:
    print("  ".join(f"{k} {v:6.2f}" for k, v in row.items() if "10log" not in k), flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--alphas", default="0,0.25,0.5,0.75,1.0", help="α values, ms")
    ap.add_argument("--json", default=None)
    ap.add_argument("--plot", default=None)
    args = ap.parse_args()
    alphas = [float(a) * 1e-3 for a in args.alphas.split(",")]
    rows = fig_4_4(alphas, log)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=2))
    if args.plot:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(6, 4))
        x = [r["alpha_ms"] for r in rows]
        for key, style in (("bpsk_direct", "r-"), ("bpsk_sim", "r--"), ("hfm_direct", "k-"),
                           ("hfm_sim", "k--")):
            ax.plot(x, [-r[f"{key}_loss_db"] for r in rows], style, label=key)
        ax.set_xlabel("distortion amplitude α (ms)")
        ax.set_ylabel("matched-filter peak (dB re undistorted)")
        ax.grid(True)
        ax.legend()
        fig.tight_layout()
        fig.savefig(args.plot, dpi=120)


if __name__ == "__main__":
    main()
