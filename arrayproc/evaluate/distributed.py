"""Monte Carlo runs spread over a Dask client, with results that do not depend on the number
of workers (DESIGN section 7; docs/scale-out.md).

The runs are cut into chunks of a fixed size (``chunk``), chunk i drawing its noise from
``numpy.random.SeedSequence(seed).spawn(n_chunks)[i]``; the chunking and the seeds depend only
on ``runs``, ``chunk`` and ``seed``, and the chunks' results are combined in chunk order, so one
worker, two or a cluster give the same numbers, bit for bit. They differ from a single-process
run of :func:`arrayproc.evaluate.montecarlo.run_case` over all runs at once, which draws every
run from one generator.

:func:`tma_chunk` is a chunk of the batch-TMA Monte Carlo (thesis fig. 3.19,
``scripts/reproduce_batch_tma.py``).

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
    import time

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
