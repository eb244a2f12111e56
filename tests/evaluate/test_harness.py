"""The Monte Carlo harness: per-run seeds from SeedSequence.spawn, results independent of the
chunking and of the number of Dask workers."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from arrayproc.evaluate.harness import monte_carlo, run_seeds, stack_runs


def _trial(rng: np.random.Generator, n: int = 3, scale: float = 1.0) -> dict:
    """A small estimation trial: the mean of n draws and the draws' sum of squares."""
    x = scale * rng.standard_normal(n)
    return {"mean": x.mean(), "x": x, "ss": float(x @ x)}


def test_run_i_draws_from_the_i_th_spawned_seed():
    got = monte_carlo(_trial, 5, 42, n=4)
    kids = np.random.SeedSequence(42).spawn(5)
    for i, k in enumerate(kids):
        want = np.random.default_rng(k).standard_normal(4)
        assert np.array_equal(got["x"][i], want)
    assert got["x"].shape == (5, 4) and got["mean"].shape == (5,)
    assert len({r.tobytes() for r in got["x"]}) == 5


@pytest.mark.parametrize("chunk", [1, 2, 3, 50])
def test_chunking_does_not_change_the_numbers(chunk):
    ref = monte_carlo(_trial, 7, 9, chunk=7)
    got = monte_carlo(_trial, 7, 9, chunk=chunk)
    for k in ref:
        assert got[k].tobytes() == ref[k].tobytes(), k


def test_seeds_differ_and_repeat():
    a = monte_carlo(_trial, 4, 1)
    b = monte_carlo(_trial, 4, 1)
    c = monte_carlo(_trial, 4, 2)
    assert a["x"].tobytes() == b["x"].tobytes()
    assert a["x"].tobytes() != c["x"].tobytes()
    # a child's stream depends on the root seed and its index only: growing the run count
    # keeps the earlier runs
    d = monte_carlo(_trial, 6, 1)
    assert d["x"][:4].tobytes() == a["x"].tobytes()
    assert [s.spawn_key for s in run_seeds(3, 5)] == [(0,), (1,), (2,)]


def test_kwargs_reach_the_trial():
    got = monte_carlo(_trial, 3, 0, n=2, scale=0.0)
    assert np.all(got["x"] == 0.0) and got["x"].shape == (3, 2)


def test_bad_arguments():
    with pytest.raises(ValueError):
        monte_carlo(_trial, 0, 1)
    with pytest.raises(ValueError):
        monte_carlo(_trial, 3, 1, chunk=0)
    with pytest.raises(ValueError):
        stack_runs([{"a": 1}, {"b": 2}])


@pytest.fixture(scope="module")
def by_value():
    """The workers need not import this test module: ship its trial by value."""
    import cloudpickle
    cloudpickle.register_pickle_by_value(sys.modules[__name__])
    yield
    cloudpickle.unregister_pickle_by_value(sys.modules[__name__])


def test_one_and_two_workers_give_the_same_bytes(clients, by_value):
    here = monte_carlo(_trial, 9, 123, chunk=2, n=5)
    one = monte_carlo(_trial, 9, 123, client=clients[1], chunk=2, n=5)
    two = monte_carlo(_trial, 9, 123, client=clients[2], chunk=4, n=5)
    for k in here:
        assert one[k].tobytes() == here[k].tobytes() == two[k].tobytes(), k
