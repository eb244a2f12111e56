"""Two bed arrays fused: cross-fix TMA with no speed prior against its CRLB.

The compact-array paper's vessel (7.3 m/s, heading 30°, 20 min centred on the CPA, a bearing
every 4 s, :mod:`.compact_paper`) passes two static arrays: array A at the origin (the CPA
distance ``d`` is measured from it) and array B ``baseline`` m east.  Independent Gaussian
bearing errors of σ at both arrays.  The cross-fix ML TMA
(:func:`arrayproc.track.batch.cross_fix.solve_cross_fix`) estimates the CV state at the
window start; its position and velocity RMSE are compared with the CRLB (inverse of the FIM
of thesis eq. (3.53) over both arrays' rows) and the mean NEES with the state dimension 4.
Optionally the single-array compact TMA with its speed prior (array A only, same noise draws)
gives what the second array buys.
"""
from __future__ import annotations

import numpy as np

from arrayproc.evaluate.scenarios.compact_paper import DT, DURATION, HEADING, SPEED
from arrayproc.track.batch.bo_tma import bearing_model
from arrayproc.track.batch.compact import solve_compact
from arrayproc.track.batch.cross_fix import solve_cross_fix
from arrayproc.track.batch.fim import bo_fim

__all__ = ["cv_truth", "run_fusion"]


def cv_truth(d_cpa: float, speed: float = SPEED) -> np.ndarray:
    """CV state [x, y, vx, vy] at the window start; CPA ``d_cpa`` from the origin mid-window."""
    u = np.array([np.sin(HEADING), np.cos(HEADING)])
    pc = d_cpa * np.array([np.cos(HEADING), -np.sin(HEADING)])
    return np.concatenate([pc - speed * DURATION / 2 * u, speed * u])


def run_fusion(d_cpa: float, baseline: float, sigma_deg: float, runs: int,
               rng: np.random.Generator, compact: bool = False) -> dict:
    """``runs`` Monte Carlo runs at CPA ``d_cpa`` (m): RMSE/CRLB of position and velocity,
    mean NEES; with ``compact`` also the single-array compact TMA's RMSE (speed prior)."""
    t1 = np.arange(0.0, DURATION + 1e-9, DT)
    sites = np.array([[0.0, 0.0], [baseline, 0.0]])
    t = np.concatenate([t1, t1])
    obs = np.repeat(sites, t1.size, axis=0)
    x = cv_truth(d_cpa)
    sig = np.deg2rad(sigma_deg)
    clean = bearing_model(x, t, obs)
    crlb = np.linalg.inv(bo_fim(x, t, obs, sig))
    info = np.linalg.inv(crlb)
    e_fx, e_cp = [], []
    for _ in range(runs):
        y = clean + rng.normal(0.0, sig, t.size)
        e = solve_cross_fix(t, y, obs, sig).state - x
        e_fx.append(e)
        if compact:
            s = solve_compact(t1, y[:t1.size], [0.0, 0.0], sig, speed_mps=SPEED,
                              sigma_speed_mps=1.5, max_range_m=1.3 * (SPEED * DURATION / 2
                                                                     + d_cpa),
                              n_grid=60, n_headings=72)
            e_cp.append(s.state - x)
    e = np.array(e_fx)
    nees = np.einsum("ri,ij,rj->r", e, info, e)
    out = {"d_cpa_m": d_cpa, "baseline_m": baseline, "sigma_deg": sigma_deg, "runs": runs,
           "rmse_pos_m": float(np.sqrt(np.mean(np.sum(e[:, :2] ** 2, 1)))),
           "crlb_pos_m": float(np.sqrt(np.trace(crlb[:2, :2]))),
           "rmse_vel_mps": float(np.sqrt(np.mean(np.sum(e[:, 2:] ** 2, 1)))),
           "crlb_vel_mps": float(np.sqrt(np.trace(crlb[2:, 2:]))),
           "mean_nees": float(nees.mean())}
    out["ratio_pos"] = out["rmse_pos_m"] / out["crlb_pos_m"]
    out["ratio_vel"] = out["rmse_vel_mps"] / out["crlb_vel_mps"]
    if compact:
        c = np.array(e_cp)
        out["compact_rmse_pos_m"] = float(np.sqrt(np.mean(np.sum(c[:, :2] ** 2, 1))))
        out["compact_rmse_vel_mps"] = float(np.sqrt(np.mean(np.sum(c[:, 2:] ** 2, 1))))
    return out
