"""The chain's source: a recording's samples as time blocks (domain ``TIME``), each with the
array's pose at its centre time (and, for ``[input] array_shape = "threaded"``, the element
positions threaded on the navigation track)."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import replace
from typing import Any

import numpy as np

from arrayproc.chain.block import Block
from arrayproc.chain.domains import Domain, TimeMeta
from arrayproc.errors import FormatError
from arrayproc.geo.threading import threaded_positions

#: Bytes of samples read from the file at once (a slab holds many blocks).
SLAB_BYTES = 8 << 20


def count_blocks(recording: Any, nfft: int, hop: int, start: int = 0,
                 stop: int | None = None) -> int:
    """How many blocks :func:`read_blocks` yields for these parameters.

    Parameters
    ----------
    recording : Recording
        The open recording.
    nfft, hop : int
        Block length and hop, samples.
    start, stop : int
        Sample range [start, stop) (stop defaults to the end).

    Returns
    -------
    int
    """
    stop = recording.n_samples if stop is None else min(int(stop), recording.n_samples)
    n = stop - start
    if n <= 0:
        return 0
    return 1 + max(0, -(-(n - nfft) // hop))


def read_blocks(recording: Any, nfft: int, hop: int | None = None, start: int = 0,
                stop: int | None = None, dtype: np.dtype | type = np.float32,
                first_index: int = 0, array_shape: str = "rigid") -> Iterator[Block]:
    """Time-domain blocks of ``nfft`` samples every ``hop`` samples over [start, stop).

    Block k covers samples [start + k·hop, start + k·hop + nfft). The last block is the first
    one that reaches ``stop``; samples past ``stop`` are zeros and the block's
    ``meta.n_valid`` says how many are real. So the hop-long heads of all blocks but the last,
    followed by the last block's valid samples, tile [start, stop) exactly. Each block carries
    the pose at its centre time. Samples are read in slabs of about :data:`SLAB_BYTES`.

    Parameters
    ----------
    recording : Recording
        The open recording (:class:`arrayproc.io.recording.Recording`).
    nfft : int
        Block length, samples.
    hop : int, optional
        Hop between block starts, samples (default ``nfft``).
    start, stop : int
        Sample range [start, stop) (stop defaults to the end).
    dtype : numpy dtype
        Sample type of the blocks.
    first_index : int
        ``index`` of the first block.
    array_shape : str
        ``"rigid"``: the file's element positions; ``"threaded"``: each block's positions
        (body frame of its pose) and pose elements threaded on the ``/nav`` track
        (:func:`arrayproc.geo.threading.threaded_positions`).

    Yields
    ------
    Block
        Domain ``TIME``, meta :class:`~arrayproc.chain.domains.TimeMeta`.
    """
    hop = nfft if hop is None else int(hop)
    nfft = int(nfft)
    if nfft < 1 or hop < 1:
        raise FormatError(f"block size and hop must be >= 1 (got {nfft}, {hop})")
    stop = recording.n_samples if stop is None else min(int(stop), recording.n_samples)
    nb = count_blocks(recording, nfft, hop, start, stop)
    fs = recording.fs
    itemsize = np.dtype(dtype).itemsize * max(1, recording.n_channels_file)
    per_slab = max(1, (SLAB_BYTES // itemsize - nfft) // hop + 1)  # blocks per slab
    k = 0
    while k < nb:
        kk = min(nb, k + per_slab)
        a = start + k * hop
        b = min(stop, start + (kk - 1) * hop + nfft)
        slab = recording.read(a, b, dtype)
        tc = (start + np.arange(k, kk) * hop + 0.5 * nfft) / fs
        poses = recording.poses(tc)
        positions = [recording.positions] * len(poses)
        if array_shape == "threaded":
            bt, world = threaded_positions(recording.nav, recording.positions, tc)
            positions = list(bt)
            poses = [replace(p, elements=w) for p, w in zip(poses, world)]
        for j in range(k, kk):
            s = start + j * hop
            seg = slab[s - a: s - a + nfft]
            n_valid = seg.shape[0]
            if n_valid < nfft:
                seg = np.concatenate(
                    [seg, np.zeros((nfft - n_valid, recording.n_channels), dtype=dtype)])
            yield Block(seg, Domain.TIME, s / fs, nfft / fs, fs, positions[j - k],
                        poses[j - k], index=first_index + j, meta=TimeMeta(s, n_valid))
        k = kk
