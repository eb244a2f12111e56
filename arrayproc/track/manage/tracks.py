"""Tracks of the multi-target manager: an id, a status and a history of estimates.

A :class:`Track` is created *tentative* by an initiator, becomes *confirmed* by the M-of-N rule
(:mod:`arrayproc.track.manage.initiate`) and ends *deleted* by a deletion rule
(:mod:`arrayproc.track.manage.delete`). Every scan the manager appends one :class:`TrackPoint`
(time, state, covariance, status, index of the measurement used or −1 when coasting) so that
the whole life of a track can be written as ``tracks`` rows (docs/formats.md).

The bookkeeping follows Blackman & Popoli, *Design and Analysis of Modern Tracking Systems*
(1999), ch. 3 (track life cycle); it is written here because the state layout and the rows
written must be ours.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum
from typing import Any

import numpy as np


class Status(str, Enum):
    """Life-cycle status of a track (the ``status`` column of the ``tracks`` kind)."""

    TENTATIVE = "tentative"
    CONFIRMED = "confirmed"
    DELETED = "deleted"


@dataclass
class TrackPoint:
    """One scan of a track: state ``x`` and covariance ``P`` (the filter's units) at ``time``
    (s), the status after the scan and the index of the measurement used (−1: coasted)."""

    time: float
    x: np.ndarray
    P: np.ndarray
    status: Status
    meas: int = -1
    logw: np.ndarray | None = None


@dataclass
class Track:
    """A track: ``id`` (unique in a run), current state ``x``, covariance ``P`` at ``time`` (s),
    ``status``, per-scan hit flags since birth (``hits``), consecutive misses, the history of
    :class:`TrackPoint`, free ``meta`` for the runner (e.g. the rows a bearing track used) and,
    for a track of several hypotheses (:class:`~arrayproc.track.manage.bank.StackedBank`), their
    log-weights ``logw``."""

    id: int
    x: np.ndarray
    P: np.ndarray
    time: float
    status: Status = Status.TENTATIVE
    hits: list[bool] = field(default_factory=list)
    misses: int = 0
    history: list[TrackPoint] = field(default_factory=list)
    meta: dict[str, Any] = field(default_factory=dict)
    logw: np.ndarray | None = None

    @property
    def alive(self) -> bool:
        """Not deleted."""
        return self.status is not Status.DELETED

    @property
    def n_hits(self) -> int:
        """Scans with an associated measurement."""
        return int(sum(self.hits))

    @property
    def confirmed_at(self) -> float | None:
        """Time (s) of the first confirmed point, None if never confirmed."""
        for p in self.history:
            if p.status is Status.CONFIRMED:
                return p.time
        return None

    def record(self, meas: int) -> None:
        """Append the current state as a history point with measurement index ``meas``."""
        self.history.append(TrackPoint(self.time, self.x.copy(), self.P.copy(), self.status,
                                       int(meas),
                                       None if self.logw is None else self.logw.copy()))

    def arrays(self) -> dict[str, np.ndarray]:
        """The history as arrays: ``time`` (n,) s, ``x`` (n, d), ``P`` (n, d, d), ``status``
        (n,) str, ``meas`` (n,) int, and ``logw`` (n, H) for a track of hypotheses."""
        h = self.history
        d = self.x.size
        out = {
            "time": np.array([p.time for p in h], float),
            "x": np.array([p.x for p in h], float).reshape(len(h), d),
            "P": np.array([p.P for p in h], float).reshape(len(h), d, d),
            "status": np.array([p.status.value for p in h], dtype=object),
            "meas": np.array([p.meas for p in h], np.int64),
        }
        if self.logw is not None:
            out["logw"] = np.array([p.logw for p in h], float).reshape(len(h), -1)
        return out


#: integer codes of the ``status`` column (io.schema: 0 tentative, 1 confirmed, 2 deleted)
STATUS_CODES = {Status.TENTATIVE.value: 0, Status.CONFIRMED.value: 1, Status.DELETED.value: 2}


def status_names(col: np.ndarray) -> np.ndarray:
    """A ``status`` column (integer codes, or names as bytes or str) as names (str)."""
    a = np.asarray(col)
    if a.dtype.kind in "iu":
        names = np.array(list(STATUS_CODES), dtype=object)
        return names[a.astype(np.int64)].astype(str)
    return np.array([v.decode() if isinstance(v, bytes) else str(v) for v in a.reshape(-1)])


__all__ = ["Status", "Track", "TrackPoint", "STATUS_CODES", "status_names"]
