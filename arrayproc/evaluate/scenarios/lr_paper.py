"""The L-R paper's section V (Das, Tiwari & Bhaumik): table I and the example run of fig. 4.

For both cases (I: constant-velocity target and CV filters; II: target turning at 3°/min and
constant-turn filters) and each filter (EKF, UKF, CKF, GHF, SRF), Monte Carlo runs with the
target side known (one filter on the true bearing) and with the side resolved (two filters on
the bearing pair, eqs. (9)-(13)), on the same noise (:func:`table_case`, or on Dask
:func:`table_case_dask`). The scenario, the fused Monte Carlo kernel and the CRLB are
:mod:`arrayproc.evaluate.montecarlo`; :func:`example_run` runs one realisation through the
filter objects and :class:`arrayproc.track.manage.lr.LRResolver`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from arrayproc.evaluate.distributed import lr_table
from arrayproc.evaluate.montecarlo import LRScenario, pcrb_case1, run_case, warm_up
from arrayproc.track.filters import make_filter
from arrayproc.track.init import initial_state
from arrayproc.track.manage.lr import LRResolver
from arrayproc.track.models.bearing import Bearing
from arrayproc.track.models.motion import make_model
from arrayproc.track.state import Context

__all__ = ["FILTERS", "PAPER", "LRScenario", "pcrb_case1", "warm_up", "example_run",
           "table_case", "table_case_dask"]

FILTERS = ["ekf", "ukf", "ckf", "ghf", "srf"]
# L-R paper table I: track loss % (known side, resolved) and relative execution time.
PAPER = {
    1: {"ekf": (5.68, 5.68, 1.0, 1.77), "ckf": (2.21, 2.21, 1.02, 2.07),
        "ukf": (1.42, 1.42, 1.10, 2.09), "ghf": (1.23, 1.23, 1.17, 2.29),
        "srf": (0.18, 0.22, 21.86, 43.47)},
    2: {"ekf": (12.25, 12.35, 0.88, 1.88), "ckf": (7.17, 7.17, 2.26, 4.10),
        "ukf": (5.90, 5.90, 2.05, 4.26), "ghf": (4.48, 4.49, 4.29, 8.56),
        "srf": (5.50, 5.57, 21.97, 44.17)},
}


def example_run(scn: LRScenario, name: str, params: dict, seed: int) -> dict[str, np.ndarray]:
    """One run through the filter objects and :class:`LRResolver` (fig. 4)."""
    g = scn.geometry()
    y1, y2, draws, rel = scn.measurements(1, seed)
    model = make_model(scn.model_name)
    meas = Bearing(sigma_deg=scn.sigma_deg)
    filt = make_filter(name, **params)
    prior = scn.prior
    n = model.ndim

    def fresh(z0):
        x0, P0 = initial_state(z0, g["own"][0], prior, n)
        # the same initial draw as the Monte Carlo kernel
        c = z0 + math.pi + draws[0, 2]
        x0[0], x0[1] = draws[0, 0] * math.sin(z0), draws[0, 0] * math.cos(z0)
        x0[2] = draws[0, 1] * math.sin(c) - g["own"][0, 2]
        x0[3] = draws[0, 1] * math.cos(c) - g["own"][0, 3]
        return filt.initialize(x0, P0)

    known = fresh(y1[0, 0])
    lr = LRResolver(filt, model, meas, [fresh(y1[0, 0]), fresh(y2[0, 0])])
    K = g["times"].size
    est_k = np.empty((K, n))
    est_r = np.empty((K, n))
    ghost = np.empty((K, n))
    w = np.empty(K)
    for k in range(K):
        if k > 0:
            T = g["times"][k] - g["times"][k - 1]
            ctx = Context(g["own"][k], g["own"][k - 1])
            known, _ = filt.update(filt.predict(known, model, T, ctx), y1[0, k], meas, ctx)
            lr.step(T, ctx, [y1[0, k], y2[0, k]])
        est_k[k] = known.x
        x, _, wk = lr.combine()
        est_r[k] = x
        ghost[k] = lr.states[1].x
        w[k] = wk[0]
    own = g["own"][:, :2]
    return {"own": own, "truth": rel[0, :, :2] + own, "known": est_k[:, :2] + own,
            "resolved": est_r[:, :2] + own, "ghost": ghost[:, :2] + own, "w": w,
            "times": g["times"]}


def table_case(scn: LRScenario, filters: list[str], runs: int, seed: int, params: dict,
               t_ref: float | None = None) -> tuple[dict, dict, float]:
    """One case of table I in this process: for each filter, ``runs`` runs with the side
    known and resolved on the same measurements (drawn from ``seed + case``); the paper's
    numbers beside ours. Times are relative to ``t_ref`` (s), by default the first filter's
    known-side time of this case (the paper's table is relative to case I's EKF: pass the
    ``t_ref`` the first case returned).

    Returns
    -------
    (dict, dict, float)
        ``{filter: row}``, the curves ``{"rmse": {filter: (pos (K,), vel (K,))},
        "bias": {filter: (K,)}}`` and ``t_ref``.
    """
    case = scn.case
    meas = scn.measurements(runs, seed + case)
    rows: dict = {}
    curves: dict = {"rmse": {}, "bias": {}}
    for name in filters:
        p = params.get(name, {})
        known = run_case(scn, name, False, runs, seed, p, meas)
        res = run_case(scn, name, True, runs, seed, p, meas)
        if t_ref is None:
            t_ref = known.seconds
        rows[name] = {
            "track_loss_pct_known_side": known.track_loss_pct,
            "track_loss_pct_resolved": res.track_loss_pct,
            "rmse_pos_final_m": float(res.rmse_pos[-1]),
            "rmse_vel_final_mps": float(res.rmse_vel[-1]),
            "rmse_pos_final_m_known_side": float(known.rmse_pos[-1]),
            "bias_norm_final_m": float(res.bias_norm[-1]),
            "true_side_pct": res.true_side_pct,
            "relative_time": res.seconds / t_ref,
            "relative_time_known_side": known.seconds / t_ref,
            "seconds_resolved": res.seconds, "seconds_known_side": known.seconds,
            "covariance_repaired_runs": known.n_repaired + res.n_repaired,
            "diverged_runs": known.n_diverged + res.n_diverged,
            "paper_track_loss_pct_known_side": PAPER[case][name][0],
            "paper_track_loss_pct_resolved": PAPER[case][name][1],
            "paper_relative_time_known_side": PAPER[case][name][2],
            "paper_relative_time_resolved": PAPER[case][name][3],
        }
        curves["rmse"][name] = (res.rmse_pos, res.rmse_vel)
        curves["bias"][name] = res.bias_norm
        del known, res
    return rows, curves, t_ref


def table_case_dask(client: Any, case: int, filters: list[str], runs: int, seed: int,
                    params: dict, chunk: int = 100, truth_noise: bool = False,
                    threads: int = 1) -> tuple[dict, dict]:
    """One case's table rows and curves from Dask chunks
    (:func:`arrayproc.evaluate.distributed.lr_table`, chunk seeds from ``seed + case``: the
    same numbers on any number of workers, not those of :func:`table_case`); times relative
    to the first filter's known-side time of the case."""
    tab = lr_table(runs, seed, [case], filters, params, client=client, chunk=chunk,
                   truth_noise=truth_noise, threads=threads)[case]
    t_ref = tab[filters[0]]["seconds_known_side"]
    rows: dict = {}
    curves: dict = {"rmse": {}, "bias": {}}
    for name in filters:
        r = tab[name]
        rows[name] = {k: v for k, v in r.items() if not isinstance(v, np.ndarray)}
        rows[name].update({
            "relative_time": r["seconds_resolved"] / t_ref,
            "relative_time_known_side": r["seconds_known_side"] / t_ref,
            "paper_track_loss_pct_known_side": PAPER[case][name][0],
            "paper_track_loss_pct_resolved": PAPER[case][name][1],
            "paper_relative_time_known_side": PAPER[case][name][2],
            "paper_relative_time_resolved": PAPER[case][name][3]})
        curves["rmse"][name] = (r["rmse_pos_m"], r["rmse_vel_mps"])
        curves["bias"][name] = r["bias_norm_m"]
    return rows, curves
