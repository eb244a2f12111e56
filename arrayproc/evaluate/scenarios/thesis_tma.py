"""Thesis 3.3.3 batch TMA: the Monte Carlo of fig. 3.19 (BO-TMA and TD-TMA against the CRLB).

Scenario of fig. 3.18 (:mod:`arrayproc.track.batch.scenarios`): source initial position
(2000 m, 1000 m), 128 hydrophones spaced 0.36 m, σ_τ = 1e-4 s for the delays and the bearing
precision σ_θ = 0.0306° the thesis takes from appendix C.1. Each run draws new Gaussian errors
and solves both estimators (differential evolution + least-squares polish); the position-error
standard deviation is compared with the CRLB (thesis eq. (3.53)). Targets: TD-TMA within 15 %
of its CRLB, BO-TMA within 30 %.

Run here, one generator feeds every run's errors; on a Dask client the runs go in chunks
seeded from ``SeedSequence(seed)`` (:func:`arrayproc.evaluate.distributed.spread`), the same
numbers on any number of workers.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from arrayproc.evaluate.distributed import spread
from arrayproc.track.batch import scenarios as S
from arrayproc.track.batch.fim import bo_fim, crlb_from_fim, td_fim

__all__ = ["SIGMA_TAU", "SIGMA_THETA", "N_H", "DX", "C", "c6_sigma_theta", "fig_3_19",
           "solver_seeds", "tma_chunk"]

SIGMA_TAU = 1e-4                    # s (thesis 3.3.3.1)
SIGMA_THETA = np.deg2rad(0.0306)    # rad (thesis 3.3.3.1, from app. C.1)
N_H, DX, C = 128, 0.36, 1500.0


def c6_sigma_theta(theta_deg: float = 90.0) -> float:
    """σ_θ (deg) of thesis eq. (C.6) for the array and σ_τ above, at cone angle θ."""
    j = (DX * np.sin(np.deg2rad(theta_deg)) / (SIGMA_TAU * C)) ** 2 * N_H * (N_H - 1) \
        * (2 * N_H - 1) / 6
    return float(np.rad2deg(1 / np.sqrt(j)))


def fig_3_19(runs: int, seed: int, client: Any = None, chunk: int = 10,
             log: Callable[[int], None] | None = None) -> dict:
    """Fig. 3.19's Monte Carlo: here, run i seeded as before (one generator for every run's
    errors, solvers seeded ``seed * 100003 + i``); on a Dask client, chunks of ``chunk`` runs,
    chunk k drawing from ``SeedSequence(seed).spawn(n_chunks)[k]``
    (:func:`arrayproc.evaluate.distributed.spread`): the same numbers on any number of
    workers, not the same as here. ``log(done)`` is called after each run done here.

    Returns
    -------
    dict
        ``runs``, ``seed``, ``seeding``, ``scenario`` and, for ``bearings`` and ``delays``,
        the per-axis standard deviations against the CRLB, the position ratio (thesis eq.
        (3.53)), biases, solver time and every run's state error.
    """
    tr = S.turn_track()
    el = S.line_elements(tr, N_H, DX)
    x = S.FIG_3_18_SOURCE
    crlb_b = crlb_from_fim(bo_fim(x, tr.time, tr.position, SIGMA_THETA))[0]
    crlb_d = crlb_from_fim(td_fim(x, tr.time, el, 0, C, SIGMA_TAU))[0]
    scenario = dict(times=tr.time, observer_pos=tr.position, elements_xy=el,
                    heading_rad=tr.heading, state=x, sigma_theta_rad=SIGMA_THETA,
                    sigma_tau_s=SIGMA_TAU, sound_speed=C)

    if client is None:
        parts = [tma_chunk(runs, seed, **scenario, log=log,
                           seeds=[seed * 100003 + i for i in range(runs)])]
    else:
        parts = spread(tma_chunk, runs, seed, client, chunk, **scenario)
    err = {m: np.concatenate([p[m] for p in parts]) for m in ("bearings", "delays")}
    t_solve = {m: float(sum(p[f"seconds_{m}"] for p in parts)) for m in ("bearings", "delays")}
    out: dict = {"runs": runs, "seed": seed,
                 "seeding": "one generator" if client is None else f"chunks of {chunk}",
                 "scenario": {
        "source_state": x.tolist(), "n_hydrophones": N_H, "spacing_m": DX,
        "sigma_tau_s": SIGMA_TAU, "sigma_theta_deg": float(np.rad2deg(SIGMA_THETA)),
        "c6_sigma_theta_broadside_deg": c6_sigma_theta(), "snapshots": int(tr.time.size),
        "ownship": "3 m/s, course 0 deg for 300 s then 315 deg for 300 s",
        "source": "3 m/s course 0 deg from (2000, 1000) m"}}
    targets = {"bearings": 0.30, "delays": 0.15}
    for m, crlb in (("bearings", crlb_b), ("delays", crlb_d)):
        e = np.array(err[m])
        std_xy = e[:, :2].std(0, ddof=1)
        bound_xy = np.sqrt(np.diag(crlb)[:2])
        pos_std = float(np.sqrt(np.sum(std_xy**2)))
        pos_bound = float(np.sqrt(np.trace(crlb[:2, :2])))
        ratio = pos_std / pos_bound
        out[m] = {"std_x_m": float(std_xy[0]), "std_y_m": float(std_xy[1]),
                  "crlb_x_m": float(bound_xy[0]), "crlb_y_m": float(bound_xy[1]),
                  "position_std_m": pos_std, "position_crlb_m": pos_bound,
                  "ratio": ratio, "bias_x_m": float(e[:, 0].mean()),
                  "bias_y_m": float(e[:, 1].mean()),
                  "std_vx_mps": float(e[:, 2].std(ddof=1)),
                  "std_vy_mps": float(e[:, 3].std(ddof=1)),
                  "crlb_vx_mps": float(np.sqrt(crlb[2, 2])),
                  "crlb_vy_mps": float(np.sqrt(crlb[3, 3])),
                  "target": f"within {targets[m]:.0%} of the CRLB",
                  "met": bool(abs(ratio - 1) <= targets[m]),
                  "seconds_per_solution": t_solve[m] / runs,
                  "errors": e.tolist()}
    return out


def solver_seeds(seed: int, n_runs: int) -> list[int]:
    """32-bit seeds of the solvers of runs ``0..n_runs-1`` of a chunk seeded ``seed``: 32 bits
    of ``SeedSequence([seed, i])`` (scipy's differential evolution takes int seeds below 2**32).

    Parameters
    ----------
    seed : int
        The chunk's seed.
    n_runs : int
        Runs in the chunk.

    Returns
    -------
    list of int
    """
    return [int(np.random.SeedSequence([seed, i]).generate_state(1)[0]) for i in range(n_runs)]


def tma_chunk(n_runs: int, seed: int, times: np.ndarray, observer_pos: np.ndarray,
              elements_xy: np.ndarray, heading_rad: np.ndarray, state: np.ndarray,
              sigma_theta_rad: float, sigma_tau_s: float, sound_speed: float = 1500.0,
              seeds: Sequence[int] | None = None,
              log: Callable[[int], None] | None = None) -> dict[str, np.ndarray]:
    """``n_runs`` Monte Carlo runs of bearings-only and time-delay TMA (thesis 3.3.3, fig.
    3.19): each run draws Gaussian errors on the bearings (σ_θ) and then on the delays (σ_τ)
    of the true source, from ``numpy.random.default_rng(seed)``, and solves both estimators
    (thesis eqs. (3.45)-(3.47) and (3.48)-(3.52)).

    Parameters
    ----------
    n_runs : int
        Runs.
    seed : int
        Seed of the measurement errors.
    times : (B,) array
        Bearing/delay times, s.
    observer_pos : (B, 2) array
        Array (reference) positions, m.
    elements_xy : (B, H, 2) array
        Element positions, m (element 0 is the delays' reference).
    heading_rad : (B,) array
        Array headings, rad.
    state : (4,) array
        True source state at the first time, m and m/s.
    sigma_theta_rad : float
        Bearing error standard deviation, rad.
    sigma_tau_s : float
        Delay error standard deviation, s.
    sound_speed : float
        m/s.
    seeds : sequence of int, optional
        Solver seed of each run (default :func:`solver_seeds` of ``seed``).
    log : callable, optional
        Called with the number of runs done after each run.

    Returns
    -------
    dict
        ``"bearings"``, ``"delays"``: (n_runs, 4) state errors (estimate − truth), m and m/s;
        ``"seconds_bearings"``, ``"seconds_delays"``: solver time summed over the runs, s.
    """
    from arrayproc.track.batch.bo_tma import bearing_model, solve_bearings
    from arrayproc.track.batch.td_tma import delay_model, solve_delays
    x = np.asarray(state, dtype=float)
    hb = bearing_model(x, times, observer_pos)
    hd = delay_model(x, times, elements_xy, 0, sound_speed)
    seeds = solver_seeds(seed, n_runs) if seeds is None else list(seeds)
    rng = np.random.default_rng(seed)
    err_b, err_d = np.empty((n_runs, 4)), np.empty((n_runs, 4))
    t_b = t_d = 0.0
    for i in range(n_runs):
        yb = hb + rng.normal(0, sigma_theta_rad, hb.shape)
        yd = hd + rng.normal(0, sigma_tau_s, hd.shape)
        t0 = time.perf_counter()
        sb = solve_bearings(times, yb, observer_pos, sigma_theta_rad, seed=seeds[i])
        t1 = time.perf_counter()
        sd = solve_delays(times, yd, elements_xy, sigma_tau_s, sound_speed=sound_speed,
                          heading_rad=heading_rad, seed=seeds[i])
        t_b += t1 - t0
        t_d += time.perf_counter() - t1
        err_b[i], err_d[i] = sb.state - x, sd.state - x
        if log is not None:
            log(i + 1)
    return {"bearings": err_b, "delays": err_d, "seconds_bearings": np.float64(t_b),
            "seconds_delays": np.float64(t_d)}
