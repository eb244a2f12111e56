"""Measurement-level Monte Carlo of the end-fire crossing in a turn: bearings-only (cone
angles, no side chosen) and bearings + frequency TMA, mean NEES against the state dimension,
and how much the frequency rows shrink the bound.

    python scripts/validate_endfire_tma.py --runs 50 [--json OUT]

Scenario (arrayproc.track.batch.scenarios.endfire_turn_track): ownship 5 kn north for 300 s,
a 45° turn to starboard at 1°/s, then 5 kn on 045; the source 3.6 km on bearing 025, 3 m/s on
course 300, tonal 300 Hz; 126 rows 5 s apart; σ 0.5° on the cone angle, 0.05 Hz on the
frequency.
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from arrayproc.track.batch import scenarios as S
from arrayproc.track.batch.bf_tma import doppler_factor, solve_bearings_frequency
from arrayproc.track.batch.bo_tma import cone_model, solve_cone, solve_line_bearings

C, F0, SIG_A, SIG_F = 1500.0, 300.0, np.deg2rad(0.5), 0.05


def trial(k: int) -> dict:
    tr, vel = S.endfire_turn_track()
    x = S.ENDFIRE_SOURCE
    rng = np.random.default_rng(10_000 + k)
    cone = np.abs(cone_model(x, tr.time, tr.position, tr.heading)
                  + rng.normal(0, SIG_A, tr.time.size))
    f = F0 * doppler_factor(x, tr.time, tr.position, vel, C) + rng.normal(0, SIG_F, cone.size)
    bo = solve_cone(tr.time, cone, tr.heading, tr.position, SIG_A, seed=k)
    bf = solve_bearings_frequency(tr.time, cone, f, tr.position, vel, SIG_A, SIG_F,
                                  heading_rad=tr.heading, sound_speed=C, seed=k)
    e4, e5 = bo.state - x, bf.state - np.append(x, F0)
    r0 = np.hypot(*x[:2])
    out = {"nees_bo": float(e4 @ np.linalg.solve(bo.crlb, e4)),
           "nees_bf": float(e5 @ np.linalg.solve(bf.crlb, e5)),
           "range_err_bo": float(np.hypot(*bo.state[:2]) / r0 - 1),
           "range_err_bf": float(np.hypot(*bf.state[:2]) / r0 - 1),
           "range_sigma_bo": bo.range_sigma, "range_sigma_bf": bf.range_sigma,
           "pos_area_ratio": float(np.sqrt(np.linalg.det(bf.crlb[:2, :2])
                                           / np.linalg.det(bo.crlb[:2, :2]))),
           "side_bo": bo.side, "side_bf": bf.side, "mirror_dchi2": bo.cost_other - bo.cost}
    if k < 5:
        out["range_global_starboard"] = float(np.hypot(*solve_line_bearings(
            tr.time, cone, tr.heading, tr.position, SIG_A, side="starboard", seed=k).state[:2]))
    return out


def summarise(rows: list[dict]) -> dict:
    col = {k: np.array([r[k] for r in rows if k in r]) for k in rows[0] if k != "side_bo"}
    return {
        "runs": len(rows),
        "mean_nees_bearings": float(col["nees_bo"].mean()), "dim_bearings": 4,
        "mean_nees_bearings_frequency": float(col["nees_bf"].mean()), "dim_bf": 5,
        "mean_range_error_bearings_pct": float(100 * col["range_err_bo"].mean()),
        "max_abs_range_error_bearings_pct": float(100 * np.abs(col["range_err_bo"]).max()),
        "mean_range_error_bf_pct": float(100 * col["range_err_bf"].mean()),
        "max_abs_range_error_bf_pct": float(100 * np.abs(col["range_err_bf"]).max()),
        "median_range_sigma_bearings_m": float(np.median(col["range_sigma_bo"])),
        "median_range_sigma_bf_m": float(np.median(col["range_sigma_bf"])),
        "median_position_bound_area_ratio": float(np.median(col["pos_area_ratio"])),
        "sides": sorted({r["side_bo"] for r in rows} | {r["side_bf"] for r in rows}),
        "min_mirror_dchi2": float(col["mirror_dchi2"].min()),
        "global_starboard_range_m": col["range_global_starboard"].tolist(),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=50)
    ap.add_argument("--json")
    a = ap.parse_args()
    s = summarise([trial(k) for k in range(a.runs)])
    print(json.dumps(s, indent=1))
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(s, fh, indent=1)


if __name__ == "__main__":
    main()
