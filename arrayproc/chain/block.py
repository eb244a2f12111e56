"""The unit of data that flows through a chain: one snapshot of one stream, with its context."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np

from arrayproc.chain.domains import META_TYPES, Domain
from arrayproc.geo.pose import Pose


@dataclass(frozen=True)
class Block:
    """One snapshot of data with its context (docs/architecture.md, Blocks and domains).

    Attributes
    ----------
    data : ndarray
        Axes named by ``domain`` (``domain.axes``).
    domain : Domain
        What the block holds (:mod:`arrayproc.chain.domains`): the axes of ``data`` and the
        class of ``meta``.
    t0 : float
        Time of the block's first sample, s since the recording start.
    span : float
        Duration covered by the block, s (``t0 + span/2`` is the snapshot's centre time).
    fs : float
        Sampling rate of the time series the block comes from, Hz.
    positions : (n, 3) ndarray
        Element positions in the body frame, m (active channels only).
    pose : Pose or None
        The array's pose at the block's centre time.
    freqs : ndarray or None
        Frequency axis, Hz, for frequency-domain blocks.
    beams : ndarray or None
        Beam axis (cone angles, deg, for line arrays; or a (n_beams, 2) array of bearing and
        elevation, deg, for 3-D steering).
    index : int
        Running number of the snapshot within its stream.
    meta : object
        The domain's typed metadata (``TimeMeta``, ``SnapshotMeta``, ``PingMeta``,
        ``EventMeta``; see :data:`arrayproc.chain.domains.META_TYPES`).

    A block's ``data`` is not modified once the block is yielded, by its producer or by any
    consumer: stages may keep references to their input blocks (the ``cbf`` stage windows its
    frames straight out of them) and a fan-out hands the same block to several branches.
    """

    data: np.ndarray
    domain: Domain
    t0: float
    span: float
    fs: float
    positions: np.ndarray
    pose: Pose | None = None
    freqs: np.ndarray | None = None
    beams: np.ndarray | None = None
    index: int = 0
    meta: Any = None

    def __post_init__(self) -> None:
        want = META_TYPES.get(self.domain) if isinstance(self.domain, Domain) else None
        if want is not None and not isinstance(self.meta, want):
            raise TypeError(f"a {self.domain.value} block needs {want.__name__} metadata, "
                            f"got {type(self.meta).__name__}")

    @property
    def t_centre(self) -> float:
        """Centre time of the snapshot, s."""
        return self.t0 + 0.5 * self.span

    def replace(self, **changes: Any) -> Block:
        """A copy with some fields changed (the data array is not copied)."""
        return dataclasses.replace(self, **changes)
