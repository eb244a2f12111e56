"""Running a chain over a recording (or a segment of it)."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from typing import Any

from arrayproc.chain.block import Block
from arrayproc.chain.graph import ChainSpec, compose, drive, set_rates
from arrayproc.chain.reader import count_blocks, read_blocks
from arrayproc.chain.segments import warmup_margin
from arrayproc.chain.stage import RunContext
from arrayproc.io.units import recording_units


def bind_chain(recording: Any, spec: ChainSpec, products: Any = None,
               log: Callable[[str], None] | None = None) -> RunContext:
    """Bind every stage of ``spec`` to one run's context (the recording, its sound speed, the
    products writer, the log) and give the products the recording's sample unit; the whole-
    file run and the live one (:mod:`arrayproc.chain.follow`) start the same way."""
    ctx = RunContext(products=products, sound_speed=recording.sound_speed, recording=recording)
    if log is not None:
        ctx.log = log
    if products is not None and hasattr(products, "set_units"):
        products.set_units(recording_units(recording))  # levels are labelled from it
    for s in spec.stages:
        s.bind(ctx)
    return ctx


def run_chain(recording: Any, spec: ChainSpec, products: Any = None,
              t_start: float | None = None, t_stop: float | None = None,
              progress: Callable[[float, float], None] | None = None,
              log: Callable[[str], None] | None = None) -> int:
    """Run a chain over a recording (or the segment [t_start, t_stop) s of it).

    Returns the number of time blocks read. Product rows outside the segment are dropped by
    the products writer's time window (set it to the same segment). ``progress``, when given,
    is called as ``progress(done_s, total_s)`` in seconds of audio after each block read (the
    command line's bar, :class:`arrayproc.app.progress.AudioBar`).
    """
    bind_chain(recording, spec, products, log)
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
    if progress:
        source = _counted(source, progress, spec.block, stop - start, fs)
    leaves, queues = compose(spec, source)
    drive(leaves, queues)
    return n


def _counted(blocks: Iterable[Block], progress: Callable[[float, float], None], block: int,
             n_samples: int, fs: float) -> Iterator[Block]:
    """The blocks, calling ``progress(seconds read, seconds to read)`` after each."""
    for k, b in enumerate(blocks, 1):
        yield b
        progress(min(k * block, n_samples) / fs, n_samples / fs)
