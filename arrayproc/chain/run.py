"""Running a chain over a recording (or a segment of it)."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from typing import Any

from arrayproc.chain.block import Block
from arrayproc.chain.graph import ChainSpec, compose, drive, set_rates
from arrayproc.chain.reader import count_blocks, read_blocks
from arrayproc.chain.segments import warmup_margin
from arrayproc.chain.stage import RunContext


def run_chain(recording: Any, spec: ChainSpec, products: Any = None,
              t_start: float | None = None, t_stop: float | None = None,
              progress: bool = False, log: Callable[[str], None] | None = None) -> int:
    """Run a chain over a recording (or the segment [t_start, t_stop) s of it).

    Returns the number of time blocks read. Product rows outside the segment are dropped by
    the products writer's time window (set it to the same segment).
    """
    ctx = RunContext(products=products, sound_speed=recording.sound_speed, recording=recording)
    if log is not None:
        ctx.log = log
    for s in spec.stages:
        s.bind(ctx)
    fs = recording.fs
    set_rates(spec, fs)
    margin = warmup_margin(spec, fs)
    a = 0.0 if t_start is None else max(0.0, t_start - margin)
    start = int(round(a * fs))
    # Read past the end by the same margin: a window stamped before t_stop may reach beyond
    # it (rows after t_stop are dropped by the products writer's time window).
    stop = recording.n_samples if t_stop is None else min(recording.n_samples,
                                                          int(round((t_stop + margin) * fs)))
    n = count_blocks(recording, spec.block, spec.block, start, stop)
    source: Iterable[Block] = read_blocks(recording, spec.block, spec.block, start, stop,
                                          array_shape=spec.array_shape)
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(total=n, unit="block", desc="process", leave=False)

        def counted(it: Iterable[Block]) -> Iterator[Block]:
            for b in it:
                yield b
                bar.update(1)
        source = counted(source)
    leaves, queues = compose(spec, source)
    try:
        drive(leaves, queues)
    finally:
        if bar is not None:
            bar.close()
    return n
