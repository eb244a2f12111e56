"""Running a chain over a recording that another process is still writing (``process
--follow``).

The recorder appends to ``/time_data`` in HDF5 SWMR mode (resize, write, flush); the recording
is opened as an SWMR reader (:class:`arrayproc.io.recording.Recording` with ``swmr=True``) and
polled. Each block of the chain's input is read as soon as its last sample is in the file and
goes through the chain at once; after it the products file (written live, SWMR) is flushed,
so a reader sees the block's rows. The stream ends when no new sample arrived for ``idle_s``
seconds, or at the first stop request (a signal: :func:`arrayproc.io.atomic.set_graceful`);
the samples in the file then are read to the end, the last block zero-padded exactly as
:func:`arrayproc.chain.reader.read_blocks` pads it, so the products are those of a run on the
file as it stands at the end.

A growing ``/nav`` (a towed array's track written with the samples) is re-read as it grows,
and a block waits until the track reaches its last sample, so the poses are those of the
whole-file run. The recording's ``growing`` attribute is True until the stream's end is
decided: a stage whose work depends on the recording's final length (``active_beams``: the
last ping's receive window runs to the end) reads it. The latency of each block is measured
from the poll that first saw its last sample to the flush after it went through the chain
(:class:`FollowStats`).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from arrayproc.chain.block import Block
from arrayproc.chain.domains import Domain, TimeMeta
from arrayproc.chain.graph import ChainSpec, compose, drive, set_rates
from arrayproc.chain.run import bind_chain
from arrayproc.io.atomic import stop_requested


@dataclass
class FollowStats:
    """Per block: end sample, wall time (``time.time()``) its last sample was first seen, and
    wall time its products were flushed; why the stream ended."""

    end_sample: list[int] = field(default_factory=list)
    seen: list[float] = field(default_factory=list)
    done: list[float] = field(default_factory=list)
    reason: str = ""

    def latencies(self) -> np.ndarray:
        """Seconds from a block's last sample seen to its products flushed."""
        n = min(len(self.seen), len(self.done))
        return np.asarray(self.done[:n]) - np.asarray(self.seen[:n])


def follow_blocks(recording: Any, nfft: int, idle_s: float, poll_s: float,
                  stats: FollowStats, after_block: Callable[[], None] = lambda: None,
                  clock: Callable[[], float] = time.time) -> Iterator[Block]:
    """Time blocks of ``nfft`` samples (hop ``nfft``) of a growing recording, each yielded as
    soon as it is complete; the last, padded one when the stream ends (module doc).

    ``after_block`` runs when the consumer asks for the next block, i.e. after the previous
    one went through the chain (the products flush); ``stats`` records the timings.
    """
    nfft = int(nfft)
    fs = recording.fs
    recording.growing = True  # stages that need the final length wait for it (active_beams)
    k = 0
    last_growth = time.monotonic()
    n_seen = -1
    while True:
        n = recording.refresh()
        now = clock()
        if n != n_seen:
            last_growth = time.monotonic()
            n_seen = n
        ending = stop_requested() is not None
        if ending:
            stats.reason = f"signal {stop_requested()}"
        elif time.monotonic() - last_growth > idle_s:
            ending = True
            stats.reason = f"no new samples for {idle_s:g} s"
        full = n // nfft
        # a block waits for the navigation to reach its end too (a towed array's /nav grows
        # with the samples): its poses are then those of the whole-file run
        nav_end = recording.nav_end() if hasattr(recording, "nav_end") else float("inf")
        if not ending and np.isfinite(nav_end):
            full = min(full, max(k, int(np.floor(nav_end * fs)) // nfft))
        if ending:
            recording.growing = False  # n is the final length from here on
        if ending and n > k * nfft:
            full = -(-n // nfft)  # the last, padded block too
        while k < full:
            s = k * nfft
            seg = recording.read(s, min(s + nfft, n))
            n_valid = seg.shape[0]
            if n_valid < nfft:
                seg = np.concatenate([seg, np.zeros((nfft - n_valid, recording.n_channels),
                                                    dtype=seg.dtype)])
            stats.end_sample.append(s + n_valid)
            stats.seen.append(now)
            pose = recording.poses(np.array([(s + 0.5 * nfft) / fs]))[0]
            yield Block(seg, Domain.TIME, s / fs, nfft / fs, fs, recording.positions, pose,
                        index=k, meta=TimeMeta(s, n_valid))
            after_block()
            stats.done.append(clock())
            k += 1
        if ending:
            return
        time.sleep(poll_s)


def follow_chain(recording: Any, spec: ChainSpec, products: Any = None, idle_s: float = 10.0,
                 poll_s: float = 0.05, log: Callable[[str], None] | None = None
                 ) -> FollowStats:
    """Run a chain over a growing recording (module doc); returns the timings.

    Parameters
    ----------
    recording : Recording
        Opened with ``swmr=True``.
    spec : ChainSpec
        The chain (its ``block`` is the hop).
    products : ProductsWriter, optional
        Written live (``live=True``); flushed after every block.
    idle_s : float
        End after this long without new samples, s.
    poll_s : float
        Interval between looks at the file, s.
    log : callable, optional
        Where the stages' warnings go.
    """
    bind_chain(recording, spec, products, log)
    set_rates(spec, recording.fs)
    recording.growing = True  # before any stage starts (they read it when they start)
    stats = FollowStats()
    flush = products.flush if products is not None else (lambda: None)
    source = follow_blocks(recording, spec.block, idle_s, poll_s, stats, after_block=flush)
    leaves, queues = compose(spec, source)
    drive(leaves, queues)
    flush()
    return stats
