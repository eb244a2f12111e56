"""Monte Carlo runs spread over a Dask client, with results that do not depend on the number
of workers (docs/scale-out.md).

The runs are cut into chunks of a fixed size (``chunk``), chunk i drawing its noise from
``numpy.random.SeedSequence(seed).spawn(n_chunks)[i]``; the chunking and the seeds depend only
on ``runs``, ``chunk`` and ``seed``, and the chunks' results are combined in chunk order, so one
worker, two or a cluster give the same numbers, bit for bit. They differ from a single-process
run of :func:`arrayproc.evaluate.montecarlo.run_case` over all runs at once, which draws every
run from one generator.

The batch-TMA Monte Carlo of thesis fig. 3.19 is spread the same way
(:func:`arrayproc.evaluate.scenarios.thesis_tma.tma_chunk`).

:func:`lr_table` computes the L-R paper's table I (Das, Tiwari & Bhaumik, section V: track loss
with the side known and resolved, eqs. (9)-(13); final RMSE; true-side share) this way; the
statistics are those of :func:`arrayproc.evaluate.montecarlo.run_case`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from arrayproc.evaluate.montecarlo import LRScenario, run_case


def chunk_seeds(runs: int, seed: int, chunk: int) -> list[tuple[int, int]]:
    """``(runs in chunk, chunk seed)`` for each chunk of at most ``chunk`` runs.

    Parameters
    ----------
    runs : int
        Monte Carlo runs in all.
    seed : int
        Root seed.
    chunk : int
        Runs per chunk (the last may hold fewer).

    Returns
    -------
    list of (int, int)
        One entry per chunk; the seed is 64 bits of ``SeedSequence(seed).spawn(n)[i]``.
    """
    if runs < 1 or chunk < 1:
        raise ValueError(f"runs and chunk must be >= 1, got {runs}, {chunk}")
    n = -(-runs // chunk)
    kids = np.random.SeedSequence(seed).spawn(n)
    return [(min(chunk, runs - i * chunk), int(k.generate_state(1, np.uint64)[0]))
            for i, k in enumerate(kids)]


def spread(fn: Callable[..., Any], runs: int, seed: int, client: Any = None, chunk: int = 100,
           **kwargs: Any) -> list[Any]:
    """Call ``fn(n_runs, chunk_seed, **kwargs)`` for every chunk, on ``client``'s workers (or
    here, one after the other, without a client); the results in chunk order.

    Parameters
    ----------
    fn : callable
        A module-level function (picklable), ``fn(n_runs, seed, **kwargs)``.
    runs : int
        Monte Carlo runs in all.
    seed : int
        Root seed.
    client : distributed.Client, optional
        Where the chunks run.
    chunk : int
        Runs per chunk: fixes the result; choose it, not the worker count, to trade memory
        and balance.
    **kwargs
        Passed to ``fn``.

    Returns
    -------
    list
        ``fn``'s results, in chunk order.
    """
    jobs = chunk_seeds(runs, seed, chunk)
    if client is None:
        return [fn(n, s, **kwargs) for n, s in jobs]
    futures = [client.submit(fn, n, s, pure=False, retries=2, **kwargs) for n, s in jobs]
    return client.gather(futures)


def spread_slices(fn: Callable[..., Any], n: int, client: Any = None, chunk: int = 50,
                  **kwargs: Any) -> list[Any]:
    """Call ``fn(lo, hi, **kwargs)`` for consecutive slices ``[lo, hi)`` of ``n`` items (at
    most ``chunk`` each), on ``client``'s workers or here; the results in slice order. For
    runs whose random streams are already keyed by run index (e.g.
    :func:`arrayproc.track.filters.particle.run_seeds`), the combined result equals one
    unsplit run's.

    Parameters
    ----------
    fn : callable
        A module-level function, ``fn(lo, hi, **kwargs)``.
    n : int
        Items (runs).
    client : distributed.Client, optional
        Where the slices run.
    chunk : int
        Items per slice.
    **kwargs
        Passed to ``fn`` (shipped once per task: keep them to the arrays the runs need).

    Returns
    -------
    list
        ``fn``'s results, in slice order.
    """
    bounds = [(lo, min(n, lo + chunk)) for lo in range(0, n, chunk)]
    if client is None:
        return [fn(lo, hi, **kwargs) for lo, hi in bounds]
    if kwargs:
        shared = client.scatter(kwargs, broadcast=True)  # sent to each worker once
        futures = [client.submit(_call_with, fn, lo, hi, shared, pure=False, retries=2)
                   for lo, hi in bounds]
    else:
        futures = [client.submit(fn, lo, hi, pure=False, retries=2) for lo, hi in bounds]
    return client.gather(futures)


def _call_with(fn: Callable[..., Any], lo: int, hi: int, kwargs: dict) -> Any:
    return fn(lo, hi, **kwargs)


def rpf_slice(lo: int, hi: int, config: Any, times: np.ndarray, observer_pos: np.ndarray,
              bearings_deg: np.ndarray, levels_db: np.ndarray | None,
              seeds: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Runs ``lo..hi`` of the SPL paper's regularised particle filter (section 4): estimates
    (R, K, 4) and resampling flags (R, K), each run on its own seed ``seeds[r]``.

    Parameters
    ----------
    lo, hi : int
        Run slice.
    config : RPFConfig
        Filter settings.
    times : (K,) array
        Measurement times, s.
    observer_pos : (K, 2) array
        Observer positions, m.
    bearings_deg : (R_all, K) array
        Bearings, deg.
    levels_db : (R_all, K) array or None
        Received levels, dB (None: bearings only).
    seeds : (R_all,) uint64 array
        Per-run seeds.

    Returns
    -------
    (ndarray, ndarray)
        ``est`` (hi − lo, K, 4) and ``resampled`` (hi − lo, K).
    """
    from arrayproc.track.filters.particle import RegularizedParticleFilter
    f = RegularizedParticleFilter(config)
    res = f.run_many(times, observer_pos, bearings_deg[lo:hi],
                     None if levels_db is None else levels_db[lo:hi], seeds=seeds[lo:hi])
    return res.est, res.resampled


def lr_chunk(n_runs: int, seed: int, case: int, filters: Sequence[str], params: dict,
             truth_noise: bool = False, threads: int = 1) -> dict[str, dict[str, Any]]:
    """One chunk of the L-R table: for each filter, the per-run quantities of the known-side
    and resolved runs on the same measurements (draws from ``seed``).

    Returns
    -------
    dict
        ``{filter: {"lost_known" (R,), "lost_res" (R,), "err2_pos" (R, K) m²,
        "err2_vel" (R, K) (m/s)², "err_xy" (R, K, 2) m, "true_side" (R,) bool,
        "err2_pos_known" (R,) m² at the last step, "seconds_known", "seconds_res"}}``.
    """
    scn = LRScenario(case=case, truth_noise=truth_noise)
    meas = scn.measurements(n_runs, seed)
    out: dict[str, dict[str, Any]] = {}
    for name in filters:
        p = params.get(name, {})
        known = run_case(scn, name, False, n_runs, seed, p, meas, threads=threads)
        res = run_case(scn, name, True, n_runs, seed, p, meas, threads=threads)
        truth = meas[3][..., :4]
        e = res.est - truth
        ek = known.est[:, -1] - truth[:, -1]
        out[name] = {
            "lost_known": known.lost, "lost_res": res.lost,
            "err2_pos": e[..., 0] ** 2 + e[..., 1] ** 2,
            "err2_vel": e[..., 2] ** 2 + e[..., 3] ** 2,
            "err_xy": e[..., :2],
            "true_side": res.weights[:, -1, 0] > 0.5,
            "err2_pos_known": ek[:, 0] ** 2 + ek[:, 1] ** 2,
            "seconds_known": known.seconds, "seconds_res": res.seconds}
    return out


def lr_table(runs: int, seed: int, cases: Sequence[int], filters: Sequence[str],
             params: dict | None = None, client: Any = None, chunk: int = 100,
             truth_noise: bool = False, threads: int = 1) -> dict[int, dict[str, dict]]:
    """The L-R paper's table I from ``runs`` runs per entry, spread over ``client``.

    Parameters
    ----------
    runs : int
        Runs per case and filter.
    seed : int
        Root seed; case c uses ``seed + c``.
    cases : sequence of int
        1 (CV target) and/or 2 (CT target).
    filters : sequence of str
        Filter names (``ekf``, ``ukf``, ``ckf``, ``ghf``, ``srf``).
    params : dict, optional
        Per-filter parameters.
    client : distributed.Client, optional
        Where the chunks run (None: here).
    chunk : int
        Runs per task.
    truth_noise : bool
        Target driven by the model's process noise.
    threads : int
        Threads each task's kernel uses (the result does not depend on it).

    Returns
    -------
    dict
        ``{case: {filter: {"track_loss_pct_known_side", "track_loss_pct_resolved",
        "rmse_pos_final_m", "rmse_vel_final_mps", "rmse_pos_final_m_known_side",
        "bias_norm_final_m", "true_side_pct", "seconds_known_side", "seconds_resolved",
        "rmse_pos_m" (K,), "rmse_vel_mps" (K,), "bias_norm_m" (K,)}}}``; RMSE and bias over
        the runs not lost (m, m/s), with the side resolved.
    """
    params = params or {}
    table: dict[int, dict[str, dict]] = {}
    for case in cases:
        parts = spread(lr_chunk, runs, seed + case, client, chunk, case=case,
                       filters=list(filters), params=params, truth_noise=truth_noise,
                       threads=threads)
        table[case] = {}
        for name in filters:
            cat = {k: np.concatenate([np.atleast_1d(p[name][k]) for p in parts])
                   for k in ("lost_known", "lost_res", "err2_pos", "err2_vel", "err_xy",
                             "true_side", "err2_pos_known")}
            ok, okk = ~cat["lost_res"], ~cat["lost_known"]
            rmse_pos = np.sqrt(cat["err2_pos"][ok].mean(axis=0)) if ok.any() else \
                np.full(cat["err2_pos"].shape[1], np.nan)
            rmse_vel = np.sqrt(cat["err2_vel"][ok].mean(axis=0)) if ok.any() else \
                np.full(cat["err2_vel"].shape[1], np.nan)
            bias = np.linalg.norm(cat["err_xy"][ok].mean(axis=0), axis=-1) if ok.any() else \
                np.full(cat["err2_pos"].shape[1], np.nan)
            table[case][name] = {
                "track_loss_pct_known_side": 100.0 * float(cat["lost_known"].mean()),
                "track_loss_pct_resolved": 100.0 * float(cat["lost_res"].mean()),
                "rmse_pos_final_m": float(rmse_pos[-1]),
                "rmse_vel_final_mps": float(rmse_vel[-1]),
                "rmse_pos_final_m_known_side":
                    float(np.sqrt(cat["err2_pos_known"][okk].mean())) if okk.any() else np.nan,
                "bias_norm_final_m": float(bias[-1]),
                "true_side_pct": 100.0 * float(cat["true_side"][ok].mean()) if ok.any()
                else float("nan"),
                "seconds_known_side": float(sum(p[name]["seconds_known"] for p in parts)),
                "seconds_resolved": float(sum(p[name]["seconds_res"] for p in parts)),
                "rmse_pos_m": rmse_pos, "rmse_vel_mps": rmse_vel, "bias_norm_m": bias,
            }
    return table
