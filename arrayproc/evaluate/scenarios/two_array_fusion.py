"""Two bed arrays fused: cross-fix TMA with no speed prior against its CRLB.

The compact-array paper's vessel (7.3 m/s, heading 30°, 20 min centred on the CPA, a bearing
every 4 s, :mod:`.compact_paper`) passes two static arrays: array A at the origin (the CPA
distance ``d`` is measured from it) and array B ``baseline`` m east.  Independent Gaussian
bearing errors of σ at both arrays.  The cross-fix ML TMA
(:func:`arrayproc.track.batch.cross_fix.solve_cross_fix`) estimates the CV state at the
window start; its position and velocity RMSE are compared with the CRLB (inverse of the FIM
of thesis eq. (3.53) over both arrays' rows) and the mean NEES with the state dimension 4.
Optionally the single-array compact TMA with its speed prior (array A only, same noise draws)
gives what the second array buys, and :func:`run_fusion_cli` runs the same through the
command line: each array's rows a products file (:func:`write_array_products`), then
``arrayproc tma A.h5 B.h5 -c cross_fix`` (each array's σ estimated from its residuals).
"""
from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

import numpy as np

from arrayproc.evaluate.scenarios.compact_paper import DT, DURATION, HEADING, SPEED
from arrayproc.track.batch.bo_tma import bearing_model
from arrayproc.track.batch.compact import solve_compact
from arrayproc.track.batch.cross_fix import solve_cross_fix
from arrayproc.track.batch.fim import bo_fim

__all__ = ["cv_truth", "run_fusion", "run_fusion_cli", "write_array_products"]


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


def write_array_products(folder: str | os.PathLike, name: str, site: np.ndarray,
                         times: np.ndarray, azimuth_deg: np.ndarray, nav: bool = True,
                         source: bool = True) -> str:
    """A static tetrahedral array's recording (``/nav`` at ``site`` unless not ``nav``) and
    its products file of azimuth rows (a ``bearings`` group as ``cbf_azel`` writes it,
    naming the recording as its ``source`` unless not ``source``); returns the products
    file's path. ``azimuth_deg`` (n,) one target's rows, or (K, n) K targets' (a row of each
    per time, the first the strongest: SNR 20, 17, … dB)."""
    from arrayproc.io.products import ProductsWriter
    from arrayproc.io.recording import RecordingWriter
    from arrayproc.sim.scenario import tetrahedron

    folder = Path(folder)
    rec = folder / f"{name}_rec.h5"
    t = np.asarray(times, float)
    with RecordingWriter(rec, 100.0, 4, positions=tetrahedron(1.84)) as w:
        w.append(np.zeros((10, 4), np.float32))
        if nav:
            w.set_nav(t, np.tile(np.asarray(site, float), (t.size, 1)), np.full(t.size, 30.0))
    az = np.atleast_2d(np.asarray(azimuth_deg, float)) % 360.0
    snr = np.repeat(20.0 - 3.0 * np.arange(az.shape[0]), t.size)
    tt = np.tile(t, az.shape[0])
    order = np.lexsort((-snr, tt))                  # by time, strongest first
    t, az, snr = tt[order], az.reshape(-1)[order], snr[order]
    n = t.size
    prod = folder / f"{name}.h5"
    with ProductsWriter(prod, source=str(rec) if source else "") as w:
        w.group("bearings", "bearings").append(
            time=t, cone_deg=np.full(n, 90.0), bearing_port_deg=az, bearing_stbd_deg=az,
            azimuth_deg=az, elevation_deg=np.zeros(n), level_db=np.full(n, 90.0),
            snr_db=snr, freq_lo=np.full(n, 100.0), freq_hi=np.full(n, 400.0),
            spl_db=np.full(n, 90.0))
    return str(prod)


def run_fusion_cli(d_cpa: float, baseline: float, sigma_deg: float, runs: int,
                   rng: np.random.Generator, folder: str | os.PathLike,
                   tma: Callable[[list[str], str, str], None] | None = None) -> dict:
    """``runs`` runs of :func:`run_fusion`'s geometry through ``arrayproc tma A.h5 B.h5 -c
    cross_fix`` (the shipped configuration: each array's σ estimated): position and velocity
    RMSE against the CRLB of the true state and σ, and the mean NEES against each run's own
    ``crlb`` row (that of its estimated σ). ``tma(inputs, config, output)`` runs the command
    (default :func:`arrayproc.evaluate.pipeline.tma`, the command's library call;
    ``scripts/validate_two_array_fusion.py`` gives the command line's ``main``)."""
    from arrayproc.data import data_path
    from arrayproc.evaluate.pipeline import tma as pipeline_tma
    from arrayproc.io.products import read_products

    run = pipeline_tma if tma is None else tma

    t1 = np.arange(0.0, DURATION + 1e-9, DT)
    sites = np.array([[0.0, 0.0], [baseline, 0.0]])
    x = cv_truth(d_cpa)
    sig = np.deg2rad(sigma_deg)
    t = np.concatenate([t1, t1])
    crlb = np.linalg.inv(bo_fim(x, t, np.repeat(sites, t1.size, axis=0), sig))
    cfg = f"{data_path('tma')}/cross_fix.toml"
    errs, nees = [], []
    for k in range(runs):
        paths = []
        for name, site in zip("AB", sites, strict=True):
            clean = bearing_model(x, t1, np.tile(site, (t1.size, 1)))
            az = np.rad2deg(clean + rng.normal(0.0, sig, t1.size))
            paths.append(write_array_products(folder, f"{name}{k}", site, t1, az))
        out = Path(folder) / f"tma{k}.h5"
        run(paths, cfg, str(out))
        g = read_products(str(out))["tma"]
        e = np.array([g["x"][0], g["y"][0], g["vx"][0], g["vy"][0]]) - x
        errs.append(e)
        nees.append(float(e @ np.linalg.solve(g["crlb"][0], e)))
    e = np.array(errs)
    out = {"d_cpa_m": d_cpa, "runs": runs,
           "rmse_pos_m": float(np.sqrt(np.mean(np.sum(e[:, :2] ** 2, 1)))),
           "crlb_pos_m": float(np.sqrt(np.trace(crlb[:2, :2]))),
           "rmse_vel_mps": float(np.sqrt(np.mean(np.sum(e[:, 2:] ** 2, 1)))),
           "crlb_vel_mps": float(np.sqrt(np.trace(crlb[2:, 2:]))),
           "mean_nees": float(np.mean(nees)),
           "max_abs_z": float(np.max(np.abs(e) / np.sqrt(np.diag(crlb))))}
    out["ratio_pos"] = out["rmse_pos_m"] / out["crlb_pos_m"]
    out["ratio_vel"] = out["rmse_vel_mps"] / out["crlb_vel_mps"]
    return out
