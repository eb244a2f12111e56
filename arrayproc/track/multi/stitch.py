"""Track segments of one source joined by their tonals: a quiet source's lines fade below the
detection threshold for longer than a track coasts, and its next track starts afresh; the
received frequencies of its tonals identify it (track-to-track association after a gap,
Blackman & Popoli 1999, sec. 9.4, on the tonal frequencies as the signature).

A confirmed track B that starts within ``reid_s`` of the last measurement of a confirmed
track A, which ended (was deleted) with no measurement from B's start on, is A's
continuation when one of B's first tonals lies within ``reid_hz`` of one of A's tonals at its
last measurement and one of B's first mirror bearings within ``reid_deg`` of A's there; of
such tracks the one nearest in frequency takes B's history, so that the TMA of the track runs
over both segments. A may still be coasting when B starts: a track that loses its source in
a turn (its predicted bearing rate carries it off the source's lines, and a new track is born
on them) coasts for ``max_misses`` scans before it is deleted. A's points from B's start on,
coasted predictions with no measurement, are dropped; its last remaining point becomes a
confirmed one; B's points keep their statuses.
Written here: the segments are this package's :class:`~arrayproc.track.manage.tracks.Track`.
"""

from __future__ import annotations

import numpy as np

from arrayproc.track.manage.tracks import Status, Track
from arrayproc.track.multi.tonals import tonal_slots

__all__ = ["stitch_by_tonals"]


def _tonals(tr: Track, n_tonals: int, last: bool, upto: int | None = None) -> np.ndarray:
    """The tonals (Hz) of the last (first) history point of ``tr`` that holds any; with
    ``upto``, the last such point at or before that index."""
    pts = tr.history[: (len(tr.history) if upto is None else upto + 1)]
    for p in (pts[::-1] if last else pts):
        f, _ = tonal_slots(p.x, n_tonals)
        if np.isfinite(f).any():
            return f[np.isfinite(f)]
    return np.zeros(0)


def _last_hit(tr: Track) -> int | None:
    """Index of the last history point of ``tr`` updated by a measurement (None: none)."""
    for k in range(len(tr.history) - 1, -1, -1):
        if tr.history[k].meas >= 0:
            return k
    return None


def _bearing_gap(a: np.ndarray, b: np.ndarray) -> float:
    """Smallest difference (deg) between the mirror bearings [β_s, β_p] of two states."""
    d = (np.asarray(a[:2])[:, None] - np.asarray(b[:2])[None, :] + 180.0) % 360.0 - 180.0
    return float(np.abs(d).min())


def stitch_by_tonals(tracks: list[Track], n_tonals: int, reid_s: float, reid_hz: float,
                     reid_deg: float) -> list[Track]:
    """The tracks with each continuation joined to its predecessor (module doc).

    Parameters
    ----------
    tracks : list of Track
        A run's tracks (the multi-target manager's, tonal states).
    n_tonals : int
        Tonal slots K of the states.
    reid_s, reid_hz, reid_deg : float
        Largest gap (s), tonal difference (Hz) and mirror-bearing difference (deg).

    Returns
    -------
    list of Track
        The tracks less the continuations, each predecessor holding its continuation's
        history (a new list; the Track objects are modified).
    """
    conf = sorted((tr for tr in tracks if tr.confirmed_at is not None and tr.history),
                  key=lambda tr: tr.history[0].time)
    gone: set[int] = set()
    for b in conf:
        fb = _tonals(b, n_tonals, last=False)
        if fb.size == 0:
            continue
        t0 = b.history[0].time
        best, best_df = None, np.inf
        for a in conf:
            if a is b or a.id in gone or a.history[-1].status is not Status.DELETED:
                continue
            k = _last_hit(a)
            if k is None or not 0.0 < t0 - a.history[k].time <= reid_s:
                continue
            fa = _tonals(a, n_tonals, last=True, upto=k)
            if fa.size == 0:
                continue
            df = float(np.abs(fa[:, None] - fb[None, :]).min())
            if df <= reid_hz and _bearing_gap(a.history[k].x, b.history[0].x) <= reid_deg \
                    and df < best_df:
                best, best_df = a, df
        if best is not None:
            cut = next(i for i, p in enumerate(best.history) if p.time >= t0) \
                if best.history[-1].time >= t0 else len(best.history)
            del best.history[cut:], best.hits[cut:]
            best.history[-1].status = Status.CONFIRMED
            best.history.extend(b.history)
            best.hits.extend(b.hits)
            best.status, best.x, best.P, best.time = b.status, b.x, b.P, b.time
            best.logw = b.logw
            gone.add(b.id)
    return [tr for tr in tracks if tr.id not in gone]
