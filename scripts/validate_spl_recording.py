"""TMA with bearings and sound pressure levels from recordings of the SPL paper's manoeuvring
scenario (docs/validation/spl_recording.md), through the library calls of the commands:

    arrayproc simulate tma_spl_paper.toml --seed N -o rec.h5
    arrayproc process rec.h5 -c arrayproc/data/chains/spl_tma.toml -o products.h5
    arrayproc track products.h5 -c <RPF, bearings only | with level = "spl_db"> -o tracks.h5

for ``--seeds`` seeds (each recording deleted once processed; per-seed results and the
products kept in ``--workdir``), scored against the simulator's truth; the same products
through the RPF with the true side of each bearing pair (no left-right hypotheses); the
measurement-level Monte Carlo with the paper's σ's, with the recordings' mean errors and
residual σ's, with the residual σ's alone, with the bearing error of the arrival's elevation
alone, with the level errors alone and with all the mean errors but the elevation's; one
recording (``--check-seed``) processed
with 60-, 20- and 10-s integrations (:mod:`arrayproc.evaluate.spl_recording`).

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
        integration_check,
        known_side_errors,
        measurement_level,
        summarise,
    )
    from arrayproc.evaluate.spl_recording_plot import plot_rmse

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=20, help="recordings (seeds first-seed, ...)")
    ap.add_argument("--first-seed", type=int, default=1)
    ap.add_argument("--duration", type=float, default=None, help="shorten the scenario, s")
    ap.add_argument("--particles", type=int, default=5000)
    ap.add_argument("--mc-runs", type=int, default=1000, help="measurement-level runs")
    ap.add_argument("--workdir", default="/tmp/spl_recording")
    ap.add_argument("--check-seed", type=int, default=1,
                    help="seed of the integration-time check (60, 20, 10 s); -1: none")
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
    zero = [0.0] * len(out["time_s"])
    out["measurement_level_elevation_only"] = measurement_level(   # bearing offsets only
        a.mc_runs, a.particles, 1, sigma_bearing_deg=out["bearing_err_residual_std_deg"],
        sigma_level_db=out["level_err_residual_std_db"],
        offsets=(out["time_s"], out["sweeps"]["elevation_bearing_err_deg"], zero))
    rest = [m - e for m, e in zip(out["bearing_err_mean_by_time_deg"],
                                  out["sweeps"]["elevation_bearing_err_deg"])]
    out["measurement_level_without_elevation"] = measurement_level(  # all but the elevation's
        a.mc_runs, a.particles, 1, sigma_bearing_deg=out["bearing_err_residual_std_deg"],
        sigma_level_db=out["level_err_residual_std_db"],
        offsets=(out["time_s"], rest, out["level_err_mean_by_time_db"]))
    out["measurement_level_level_bias_only"] = measurement_level(   # level offsets only
        a.mc_runs, a.particles, 1, sigma_bearing_deg=out["bearing_err_residual_std_deg"],
        sigma_level_db=out["level_err_residual_std_db"],
        offsets=(out["time_s"], zero, out["level_err_mean_by_time_db"]))
    if a.check_seed >= 0:
        out["integration_check"] = {"seed": a.check_seed, "snapshots": integration_check(
            a.check_seed, a.workdir, (60, 20, 10), a.duration)}
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
    if "integration_check" in out:
        print(json.dumps(out["integration_check"], indent=1))
    for k in ("time_min", "rmse_bot_m", "rmse_spl_m", "rmse_known_side_bot_m",
              "rmse_known_side_spl_m"):
        print(k, " ".join(f"{v:.0f}" if k != "time_min" else f"{v:.1f}" for v in out[k]))
    for key in ("measurement_level_paper", "measurement_level_recording",
                "measurement_level_residual", "measurement_level_elevation_only",
                "measurement_level_level_bias_only", "measurement_level_without_elevation"):
        for lab in ("bot", "spl"):
            print(key, lab, " ".join(f"{v:.0f}" for v in out[key][f"rmse_{lab}_m"]))


if __name__ == "__main__":
    main()
