"""The Monte Carlo harness: a trial function run ``runs`` times, each run on its own seed.

Run i draws from ``numpy.random.default_rng(SeedSequence(seed).spawn(runs)[i])``: the seeds
depend only on ``seed`` and ``runs``, never on how the runs are grouped, so the results are the
same, bit for bit, run one after the other here, in chunks of any size, or on any number of
Dask workers (``client``). Chunks of ``chunk`` runs are the unit of work shipped to a worker
(:func:`arrayproc.evaluate.distributed.spread_slices`); the results come back in run order.

A trial is a module-level function ``trial(rng, **kwargs) -> dict`` (picklable, for Dask) whose
values are numbers or arrays of the same shape in every run; :func:`monte_carlo` stacks them
along a new first axis. The statistics over the runs (RMSE, NEES, CRLB ratios) are in
:mod:`arrayproc.evaluate.accuracy`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from arrayproc.evaluate.distributed import spread_slices

__all__ = ["run_seeds", "monte_carlo", "stack_runs"]

Trial = Callable[..., Mapping[str, Any]]


def run_seeds(runs: int, seed: int) -> list[np.random.SeedSequence]:
    """The seed sequence of each run: ``SeedSequence(seed).spawn(runs)``.

    Parameters
    ----------
    runs : int
        Monte Carlo runs, >= 1.
    seed : int
        Root seed (>= 0).

    Returns
    -------
    list of numpy.random.SeedSequence
        Statistically independent streams, one per run.
    """
    if runs < 1:
        raise ValueError(f"runs must be >= 1, got {runs}")
    return np.random.SeedSequence(seed).spawn(runs)


def _trial_slice(lo: int, hi: int, trial: Trial, seeds: list[np.random.SeedSequence],
                 kwargs: Mapping[str, Any]) -> list[Mapping[str, Any]]:
    return [trial(np.random.default_rng(seeds[i]), **kwargs) for i in range(lo, hi)]


def stack_runs(results: list[Mapping[str, Any]]) -> dict[str, np.ndarray]:
    """Stack per-run results ``[{key: value}, ...]`` into ``{key: array (runs, ...)}``.

    Parameters
    ----------
    results : list of mappings
        One per run, all with the same keys and value shapes.

    Returns
    -------
    dict of ndarray
    """
    if not results:
        raise ValueError("no runs to stack")
    keys = list(results[0])
    for r in results[1:]:
        if list(r) != keys:
            raise ValueError(f"trial results differ in keys: {keys} vs {list(r)}")
    return {k: np.stack([np.asarray(r[k]) for r in results]) for k in keys}


def monte_carlo(trial: Trial, runs: int, seed: int, client: Any = None, chunk: int = 50,
                **kwargs: Any) -> dict[str, np.ndarray]:
    """Run ``trial(rng, **kwargs)`` ``runs`` times, run i on its own seed (module docstring).

    Parameters
    ----------
    trial : callable
        ``trial(rng, **kwargs) -> {name: number or array}``; module-level for Dask.
    runs : int
        Number of runs.
    seed : int
        Root seed: the same seed gives the same numbers whatever ``client`` and ``chunk``.
    client : distributed.Client, optional
        Where the chunks run (None: here, in order).
    chunk : int
        Runs per task.
    **kwargs
        Passed to every trial (shipped once per worker with a client).

    Returns
    -------
    dict of ndarray
        Each trial output stacked over the runs, shape (runs, ...).
    """
    if chunk < 1:
        raise ValueError(f"chunk must be >= 1, got {chunk}")
    seeds = run_seeds(runs, seed)
    parts = spread_slices(_trial_slice, runs, client, chunk, trial=trial, seeds=seeds,
                          kwargs=kwargs)
    return stack_runs([r for p in parts for r in p])
