"""Monte Carlo on Dask: the batch-TMA reproduction (thesis fig. 3.19) spread over 1
and over 2 workers gives the same numbers, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from arrayproc.evaluate.distributed import chunk_seeds, spread
from arrayproc.evaluate.scenarios.thesis_tma import fig_3_19, solver_seeds, tma_chunk

distributed = pytest.importorskip("distributed")


def test_batch_tma_same_numbers_on_one_and_two_workers(clients):
    """4 runs in chunks of 2 (seeded from SeedSequence(3)): every run's BO- and TD-TMA errors
    and the table's statistics are the same bytes on 1 and on 2 workers; the chunks draw
    different errors."""
    one = fig_3_19(4, 3, clients[1], chunk=2)
    two = fig_3_19(4, 3, clients[2], chunk=2)
    for m in ("bearings", "delays"):
        e1, e2 = np.array(one[m]["errors"]), np.array(two[m]["errors"])
        assert e1.shape == (4, 4) and e1.tobytes() == e2.tobytes(), m
        assert len({tuple(r) for r in e1}) == 4, m  # four different draws
        for k in ("position_std_m", "position_crlb_m", "ratio", "bias_x_m", "std_vx_mps"):
            assert one[m][k] == two[m][k], (m, k)
    assert one["seeding"] == two["seeding"] == "chunks of 2"


def test_tma_chunk_draws_and_seeds():
    """A chunk draws its bearing and delay errors from default_rng(seed), run after run: the
    first run's estimate with those errors equals the chunk's first row; spread() hands each
    chunk its SeedSequence child."""
    from arrayproc.track.batch import scenarios as S
    from arrayproc.track.batch.bo_tma import bearing_model, solve_bearings
    tr = S.turn_track()
    el = S.line_elements(tr, 16, 0.5)
    x = S.FIG_3_18_SOURCE
    sig_b, sig_d = np.deg2rad(0.05), 1e-4
    kw = dict(times=tr.time, observer_pos=tr.position, elements_xy=el, heading_rad=tr.heading,
              state=x, sigma_theta_rad=sig_b, sigma_tau_s=sig_d)
    got = tma_chunk(1, 11, **kw)
    hb = bearing_model(x, tr.time, tr.position)
    yb = hb + np.random.default_rng(11).normal(0, sig_b, hb.shape)
    ref = solve_bearings(tr.time, yb, tr.position, sig_b, seed=solver_seeds(11, 1)[0])
    assert np.array_equal(got["bearings"][0], ref.state - x)
    assert all(0 <= s < 2**32 for s in solver_seeds(5, 10)) and len(set(solver_seeds(5, 10))) == 10
    seeds = [s for _, s in chunk_seeds(3, 9, 1)]
    assert spread(_echo_seed, 3, 9, None, 1) == seeds and len(set(seeds)) == 3


def _echo_seed(n_runs: int, seed: int) -> int:
    return seed
