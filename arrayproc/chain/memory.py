"""Feed an in-memory signal to a stage as a stream of time blocks (no recording file).

For scripted experiments and the reproduction scenarios: the blocks are those the chain's
reader would produce from a recording holding ``x`` (float32 samples, consecutive sample
indices from ``start``), cut into blocks whose sizes cycle through ``sizes``.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np

from arrayproc.chain.block import Block
from arrayproc.chain.domains import Domain, TimeMeta

__all__ = ["array_blocks", "run_stage"]


def array_blocks(x: np.ndarray, fs: float, positions: np.ndarray | None = None,
                 sizes: Sequence[int] = (8192,), start: int = 0) -> Iterator[Block]:
    """Time blocks of ``x`` (n, channels), block k holding ``sizes[k % len(sizes)]`` samples.

    Parameters
    ----------
    x : (n, C) array
        Samples (cast to float32, as a recording stores them).
    fs : float
        Sample rate, Hz.
    positions : (C, 3) array, optional
        Element positions, m (default zeros).
    sizes : sequence of int
        Block sizes, cycled.
    start : int
        Sample index of ``x[0]`` in the stream.

    Yields
    ------
    Block
        ``Domain.TIME`` blocks with ``TimeMeta(start + i, size)``.
    """
    if positions is None:
        positions = np.zeros((x.shape[1], 3))
    i, k = 0, 0
    while i < x.shape[0]:
        n = min(sizes[k % len(sizes)], x.shape[0] - i)
        yield Block(x[i:i + n].astype(np.float32), Domain.TIME, (start + i) / fs, n / fs, fs,
                    positions, None, meta=TimeMeta(start + i, n))
        i += n
        k += 1


def run_stage(stage: Any, x: np.ndarray, fs: float, positions: np.ndarray | None = None,
              sizes: Sequence[int] = (8192,), start: int = 0) -> tuple[np.ndarray, list[Block]]:
    """Run ``stage`` over :func:`array_blocks` of ``x``; its outputs' data concatenated along
    the first axis, and the output blocks.

    Returns
    -------
    (ndarray, list of Block)
    """
    out = list(stage.process(array_blocks(x, fs, positions, sizes, start)))
    return np.concatenate([o.data for o in out]), out
