"""Readings of the L-R paper's section V tested against table I, known side only.

Each *reading* changes one or two settings the paper leaves open or could be read otherwise
(the filters' process-noise intensity and its units, the bearing noise of data and filter,
the turn-rate prior of the constant-turn filters, process noise in the truth) and runs the
five filters of :mod:`arrayproc.evaluate.montecarlo` on the same measurements, printing the %
of lost tracks (final range error > 1 km) and the final position RMSE of the kept runs. The
results behind docs/validation.md ("Tracking I", readings 10-13) are in
docs/results/lr_case1_readings.jsonl.

    .venv/bin/python scripts/explore_lr_readings.py --runs 20000 --reading base,q_x40 \
        [--out results.jsonl]

Names: ``--list`` prints them.
"""

from __future__ import annotations

import argparse
import json
import math
import time

import numpy as np

from arrayproc.evaluate import montecarlo as mc
from arrayproc.track.filters import make_filter
from arrayproc.track.init import TrackPrior
from arrayproc.track.models.motion import Q1_PAPER, Q2_PAPER, make_model

FILTERS = ["ekf", "ukf", "ckf", "ghf", "srf"]
PARAMS = {"ghf": {"gh_order": 3}, "srf": {"likelihood": "exact"}}
PAPER = {1: [5.68, 1.42, 2.21, 1.23, 0.18], 2: [12.25, 5.90, 7.17, 4.48, 5.50]}
SLIP60 = {"q1": 1.944e-6 * 1e6 / 60.0**2, "q2": 3.78e-7 / 60.0**2}  # /60² instead of /60³


def _psi(deg_per_min: float) -> dict:
    return {"prior": TrackPrior(sigma_turn_deg_s=deg_per_min / 60.0)}


READINGS: dict[str, dict] = {
    "base": {},
    "q_x0.216_m2s3": {"q1": 1.944e-6},  # the printed number used as m²/s³
    "q0": {"q1": 0.0},
    **{f"q_x{f:g}": {"q1": f * Q1_PAPER} for f in (0.1, 3, 10, 20, 30, 40, 50, 100, 1000)},
    "q_slip60": dict(SLIP60),
    "q_slip60_truthnoise": {**SLIP60, "truth_model_q": True, "scn": {"truth_noise": True}},
    "sig2": {"sig_data": 2.0},
    "sig3": {"sig_data": 3.0},
    "sig2_filt1.5": {"sig_data": 2.0, "sig_filt": 1.5},
    "sig1.5_filt1": {"sig_data": 1.5, "sig_filt": 1.0},
    "sig1.5_filt0.86": {"sig_data": 1.5, "sig_filt": math.degrees(0.015)},
    "sig1.5_filt3": {"sig_data": 1.5, "sig_filt": 3.0},
    "psi1": {"scn": _psi(1.0)},
    "q_x40_psi1": {"q1": 40 * Q1_PAPER, "scn": _psi(1.0)},
    "q_x40_psi1_truthnoise": {"q1": 40 * Q1_PAPER, "scn": {**_psi(1.0), "truth_noise": True}},
    "q_x50_psi0.75": {"q1": 50 * Q1_PAPER, "scn": _psi(0.75)},
    "q_slip60_psi0.5": {**SLIP60, "scn": _psi(0.5)},
}


def run_known(case: int, name: str, runs: int, seed: int = 2024, q1: float = Q1_PAPER,
              q2: float = Q2_PAPER, sig_data: float = 1.5, sig_filt: float | None = None,
              meas=None, scn: dict | None = None, truth_model_q: bool = False):
    """Loss %, final position RMSE (m) of the kept runs, and the measurements (for reuse)."""
    sig_filt = sig_data if sig_filt is None else sig_filt
    scenario = mc.LRScenario(case=case, sigma_deg=sig_data, **(scn or {}))
    if meas is None:
        if truth_model_q:  # truth driven by the same (re-read) process noise as the filters
            orig = mc.make_model
            mc.make_model = lambda n, *a, **k: orig(n, q1, q2)
            try:
                meas = scenario.measurements(runs, seed + case)
            finally:
                mc.make_model = orig
        else:
            meas = scenario.measurements(runs, seed + case)
    g = scenario.geometry()
    model = make_model(scenario.model_name, q1, q2)
    filt = make_filter(name, **PARAMS.get(name, {}))
    y1, _, draws, rel = meas
    prior = scenario.prior.as_array()
    prior[4] = math.radians(sig_filt)
    est, _, status = mc._run_threads(filt, model, np.ascontiguousarray(y1[..., None]),
                                     g["times"], g["own"], math.radians(sig_filt), prior,
                                     np.ascontiguousarray(draws), 1)
    truth = rel[..., :4]
    r_est = np.hypot(est[:, -1, 0], est[:, -1, 1])
    r_true = np.hypot(truth[:, -1, 0], truth[:, -1, 1])
    lost = (np.abs(r_est - r_true) > 1000.0) | ((status & 4) != 0) | ~np.isfinite(r_est)
    e = (est - truth)[~lost]
    rmse = float(np.sqrt(np.mean(e[:, -1, 0] ** 2 + e[:, -1, 1] ** 2)))
    return 100.0 * lost.mean(), rmse, meas


def variant(label: str, runs: int, out: str | None) -> dict:
    kw = READINGS[label]
    res: dict = {"label": label, "runs": runs}
    t0 = time.time()
    for case in (1, 2):
        meas = None
        losses, rmses = [], []
        for name in FILTERS:
            loss, rmse, meas = run_known(case, name, runs, meas=meas, **kw)
            losses.append(loss)
            rmses.append(rmse)
        res[f"case{case}_loss"], res[f"case{case}_rmse"] = losses, rmses
    res["sec"] = time.time() - t0
    print(f"{label} | runs {runs} | " + " | ".join(
        f"case {c}: " + "/".join(f"{x:.2f}" for x in res[f"case{c}_loss"])
        + f" ({min(res[f'case{c}_rmse']):.0f}-{max(res[f'case{c}_rmse']):.0f} m)"
        for c in (1, 2)) + f" | paper {PAPER[1]} / {PAPER[2]}", flush=True)
    if out:
        with open(out, "a") as fh:
            fh.write(json.dumps({**res, "kw": {k: str(v) for k, v in kw.items()}}) + "\n")
    return res


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5000)
    ap.add_argument("--reading", default="base", help="comma-separated reading names")
    ap.add_argument("--out", default=None, help="append results as JSON lines to this file")
    ap.add_argument("--list", action="store_true", help="print the reading names and exit")
    args = ap.parse_args()
    if args.list:
        print("\n".join(READINGS))
        return
    for name in args.reading.split(","):
        variant(name, args.runs, args.out)


if __name__ == "__main__":
    main()
