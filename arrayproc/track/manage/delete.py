"""Coasting and deletion of confirmed tracks (Blackman & Popoli 1999, sec. 3.3).

A confirmed track coasts (prediction only) through missed scans; it is deleted after
``max_misses`` consecutive misses, after ``max_coast_s`` seconds without a measurement, or
when its position uncertainty (square root of the largest eigenvalue of the position block of
P) exceeds ``max_sigma``. Duplicates — two confirmed tracks whose states stay within a
Mahalanobis distance ``merge_d2`` of each other for ``merge_scans`` scans — are resolved by
deleting the younger one.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from arrayproc.errors import ConfigError
from arrayproc.track.manage.tracks import Status, Track


@dataclass(frozen=True)
class DeletionRule:
    """Deletion thresholds; ``None`` disables a test.

    Parameters
    ----------
    max_misses : int
        Consecutive missed scans after which a confirmed track is deleted.
    max_coast_s : float or None
        Seconds without a measurement after which any track is deleted.
    max_sigma : float or None
        Largest position standard deviation (the state's position units) tolerated.
    pos : tuple of int
        Indices of the position components in the state.
    merge_d2 : float or None
        Mahalanobis distance (d², with the summed covariances) under which two confirmed
        tracks count as duplicates.
    merge_scans : int
        Consecutive scans as duplicates before the younger is deleted.
    window, min_hits : int
        Delete a confirmed track with fewer than ``min_hits`` hits in its last ``window``
        scans (a false track fed by sporadic clutter); ``window`` None disables the test.
    distinct : callable or None
        ``distinct(a, b)`` True when tracks a and b hold different targets whatever their
        distance (e.g. disjoint tonal frequencies): such a pair is never a duplicate.
    """

    max_misses: int = 5
    max_coast_s: float | None = None
    max_sigma: float | None = None
    pos: tuple[int, ...] = (0,)
    merge_d2: float | None = None
    merge_scans: int = 3
    window: int | None = None
    min_hits: int = 0
    distinct: Callable[[Track, Track], bool] | None = None

    def __post_init__(self) -> None:
        if not (isinstance(self.max_misses, int) and self.max_misses >= 1):
            raise ConfigError("deletion: max_misses must be an integer >= 1")
        for k in ("max_coast_s", "max_sigma", "merge_d2"):
            v = getattr(self, k)
            if v is not None and not v > 0:
                raise ConfigError(f"deletion: {k} must be > 0")
        if not (isinstance(self.merge_scans, int) and self.merge_scans >= 1):
            raise ConfigError("deletion: merge_scans must be an integer >= 1")
        if self.window is not None and not (isinstance(self.window, int)
                                            and 1 <= self.min_hits <= self.window):
            raise ConfigError("deletion: need integers 1 <= min_hits <= window")

    def should_delete(self, track: Track, t: float, last_hit_time: float) -> bool:
        """True when confirmed ``track`` must be deleted at time ``t`` (s), its latest hit at
        ``last_hit_time`` (s)."""
        if track.status is not Status.CONFIRMED:
            return False
        if track.misses >= self.max_misses:
            return True
        if self.window is not None and len(track.hits) >= self.window \
                and sum(track.hits[-self.window:]) < self.min_hits:
            return True
        if self.max_coast_s is not None and t - last_hit_time > self.max_coast_s:
            return True
        if self.max_sigma is not None:
            idx = np.asarray(self.pos)
            lam = np.linalg.eigvalsh(track.P[np.ix_(idx, idx)]).max()
            if math_sqrt(lam) > self.max_sigma:
                return True
        return False

    def duplicates(self, tracks: list[Track]) -> list[Track]:
        """Update the duplicate counters of confirmed ``tracks`` and return the younger member
        of each pair that has been a duplicate for ``merge_scans`` scans."""
        if self.merge_d2 is None:
            return []
        live = [tr for tr in tracks if tr.status is Status.CONFIRMED]
        close: set[tuple[int, int]] = set()
        idx = np.asarray(self.pos)
        for a in range(len(live)):
            for b in range(a + 1, len(live)):
                ta, tb = live[a], live[b]
                if self.distinct is not None and self.distinct(ta, tb):
                    continue
                d = ta.x[idx] - tb.x[idx]
                S = ta.P[np.ix_(idx, idx)] + tb.P[np.ix_(idx, idx)]
                if float(d @ np.linalg.solve(S, d)) < self.merge_d2:
                    close.add((min(ta.id, tb.id), max(ta.id, tb.id)))
        out = []
        by_id = {tr.id: tr for tr in live}
        for tr in live:
            cnt = tr.meta.setdefault("_dup", {})
            for key in list(cnt):
                if key not in close:
                    del cnt[key]
        for key in close:
            old = by_id[key[0]]
            n = old.meta["_dup"].get(key, 0) + 1
            old.meta["_dup"][key] = n
            if n >= self.merge_scans:
                young = by_id[key[1]]
                # the one with fewer hits goes (the younger on a tie)
                gone = young if young.n_hits <= old.n_hits else old
                if gone not in out:
                    out.append(gone)
        return out


def math_sqrt(v: float) -> float:
    """√max(v, 0)."""
    return float(np.sqrt(max(float(v), 0.0)))


__all__ = ["DeletionRule"]
