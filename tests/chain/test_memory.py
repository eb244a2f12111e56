"""In-memory block feeding: sizes cycle, sample indices and times follow ``start``."""

from __future__ import annotations

import numpy as np

from arrayproc.chain.domains import Domain
from arrayproc.chain.memory import array_blocks, run_stage


class _Pass:
    def process(self, blocks):
        yield from blocks


def test_blocks_cover_the_signal_in_cycled_sizes():
    x = np.arange(23.0 * 2).reshape(23, 2)
    bl = list(array_blocks(x, 10.0, None, (5, 3), start=100))
    assert [b.data.shape[0] for b in bl] == [5, 3, 5, 3, 5, 2]
    assert [b.meta.sample0 for b in bl] == [100, 105, 108, 113, 116, 121]
    assert bl[1].t0 == 10.5 and bl[1].span == 0.3 and bl[-1].meta.n_valid == 2
    assert all(b.domain is Domain.TIME and b.data.dtype == np.float32 for b in bl)
    assert np.array_equal(np.concatenate([b.data for b in bl]), x.astype(np.float32))
    assert np.array_equal(bl[0].positions, np.zeros((2, 3)))


def test_run_stage_concatenates_the_outputs():
    x = np.random.default_rng(0).standard_normal((50, 3))
    pos = np.ones((3, 3))
    y, out = run_stage(_Pass(), x, 100.0, pos, (7,))
    assert len(out) == 8 and np.array_equal(y, x.astype(np.float32))
    assert np.array_equal(out[0].positions, pos)
