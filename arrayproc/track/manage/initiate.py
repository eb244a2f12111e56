"""Track initiation and confirmation: the manager's initiator and confirmer parts.

The **initiator** is any callable ``initiator(Z, t, ctx, j)`` returning the state ``(x, P)``
(a bank's track: ``(x, P, logw)``) of a tentative track from measurement j of the scan, or
None (e.g. :meth:`arrayproc.track.models.bearing_range_rate.BearingRangeRate.inverse` behind a
lambda, :func:`arrayproc.track.manage.mirrored.mirrored_initial`).

Track confirmation by the M-of-N rule (Blackman & Popoli 1999, sec. 3.2; Bar-Shalom,
Willett & Tian 2011, sec. 3.1).

A tentative track is confirmed as soon as it has at least M hits (scans with an associated
measurement) among its first N scans, and deleted as soon as M hits can no longer be reached
within those N scans. A one-point initiator (the mode's ``initiate(z, t, ctx)``) starts the
tentative track; only measurements outside every live track's gate start one.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from arrayproc.errors import ConfigError
from arrayproc.track.manage.tracks import Status, Track

#: ``initiator(Z, t, ctx, j) -> (x, P)``, ``(x, P, logw)`` for a bank, or None
Initiator = Callable[[np.ndarray, float, Any, int], "tuple[np.ndarray, ...] | None"]


@dataclass(frozen=True)
class MofN:
    """M-of-N confirmation: ``m`` hits in the first ``n`` scans (1 <= m <= n)."""

    m: int = 3
    n: int = 5

    def __post_init__(self) -> None:
        if not (isinstance(self.m, int) and isinstance(self.n, int) and 1 <= self.m <= self.n):
            raise ConfigError(f"confirmation: need integers 1 <= m <= n, got m={self.m}, "
                              f"n={self.n}")

    def apply(self, track: Track) -> Status:
        """New status of a tentative track after its latest scan (confirmed tracks are left
        to the deletion rule).

        Parameters
        ----------
        track : Track
            With ``hits`` holding one flag per scan since birth.

        Returns
        -------
        Status
            The status it takes (also set on the track).
        """
        if track.status is not Status.TENTATIVE:
            return track.status
        seen = track.hits[:self.n]
        got = int(sum(seen))
        if got >= self.m:
            track.status = Status.CONFIRMED
        elif got + (self.n - len(seen)) < self.m:
            track.status = Status.DELETED
        return track.status


__all__ = ["MofN", "Initiator"]
