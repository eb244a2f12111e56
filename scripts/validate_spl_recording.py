"""TMA with bearings and sound pressure levels from recordings of the SPL paper's manoeuvring
scenario (docs/validation/spl_recording.md), through the library calls of the commands:

    arrayproc simulate tma_spl_paper.toml --seed N -o rec.h5
    arrayproc process rec.h5 -c arrayproc/data/chains/spl_tma.toml -o products.h5
    arrayproc track products.h5 -c <RPF, bearings only | with level = "spl_db"> -o tracks.h5

for ``--seeds`` seeds (each recording deleted once processed; per-seed results and the
products kept in ``--workdir``), scored against the simulator's truth; the same products
through the RPF with the true side of each bearing pair (no left-right hypotheses); the
measurement-level Monte Carlo with the paper's σ's, with the recordings' mean errors and
residual σ's, and with the residual σ's alone (:mod:`arrayproc.evaluate.spl_recording`).

    python scripts/validate_spl_recording.py --seeds 20 --workdir /tmp/spl \
        --json docs/results/spl_recording.json --figure docs/figures/spl_recording_rmse.png
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np


def main() -> None:
    from arrayproc.evaluate.accuracy import rmse
    from arrayproc.evaluate.spl_recording import (
        cached_seed,
        known_side_errors,
        measurement_level,
        plot_rmse,
        summarise,
    )

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=20, help="recordings (seeds first-seed, ...)")
    ap.add_argument("--first-seed", type=int, default=1)
    ap.add_argument("--duration", type=float, default=None, help="shorten the scenario, s")
    ap.add_argument("--particles", type=int, default=5000)
    ap.add_argument("--mc-runs", type=int, default=1000, help="measurement-level runs")
    ap.add_argument("--workdir", default="/tmp/spl_recording")
    ap.add_argument("--json", default=None)
    ap.add_argument("--figure", default=None)
    a = ap.parse_args()
    runs = []
    for s in range(a.first_seed, a.first_seed + a.seeds):
        t0 = time.perf_counter()
        runs.append(cached_seed(s, a.workdir, a.duration, a.particles,
                                log=lambda m: print(m, file=sys.stderr)))
        print(f"seed {s}: {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    out = {"scenario": "tma_spl_paper", "chain": "spl_tma", "particles": a.particles,
           "duration_s": a.duration, **summarise(runs)}
    known = [known_side_errors(f"{a.workdir}/products_{s}.h5", a.particles, s)
             for s in out["seeds"]]
    for lab in ("bot", "spl"):
        out[f"rmse_known_side_{lab}_m"] = rmse(np.stack([k[f"err_{lab}_m"] for k in known])
                                               ).tolist()
    out["measurement_level_paper"] = measurement_level(a.mc_runs, a.particles, 1)
    out["measurement_level_recording"] = measurement_level(
        a.mc_runs, a.particles, 1, sigma_bearing_deg=out["bearing_err_residual_std_deg"],
        sigma_level_db=out["level_err_residual_std_db"],
        offsets=(out["time_s"], out["bearing_err_mean_by_time_deg"],
                 out["level_err_mean_by_time_db"]))
    out["measurement_level_residual"] = measurement_level(
        a.mc_runs, a.particles, 1, sigma_bearing_deg=out["bearing_err_residual_std_deg"],
        sigma_level_db=out["level_err_residual_std_db"])
    text = json.dumps(out, indent=1)
    if a.json:
        with open(a.json, "w", encoding="utf-8") as f:
            f.write(text + "\n")
    if a.figure:
        plot_rmse(out, a.figure)
    keys = ("level_err_mean_db", "level_err_std_db", "level_err_residual_std_db",
            "bearing_err_mean_deg", "bearing_err_std_deg", "bearing_err_residual_std_deg",
            "median_final_error_bot_m", "median_final_error_spl_m", "segments")
    print(json.dumps({k: out[k] for k in keys}, indent=1))
    for k in ("time_min", "rmse_bot_m", "rmse_spl_m", "rmse_known_side_bot_m",
              "rmse_known_side_spl_m"):
        print(k, " ".join(f"{v:.0f}" if k != "time_min" else f"{v:.1f}" for v in out[k]))
    for key in ("measurement_level_paper", "measurement_level_recording",
                "measurement_level_residual"):
        for lab in ("bot", "spl"):
            print(key, lab, " ".join(f"{v:.0f}" for v in out[key][f"rmse_{lab}_m"]))


if __name__ == "__main__":
    main()
