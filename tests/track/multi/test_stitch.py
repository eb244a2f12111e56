"""Track segments of one source joined by their tonals (``track/multi/stitch.py``): after a
gap, and while the lost track still coasts when the new one starts."""

from __future__ import annotations

import numpy as np
import pytest

from arrayproc.track.manage.tracks import Status, Track, TrackPoint
from arrayproc.track.multi.stitch import stitch_by_tonals

K = 2


def _state(bearing: float, tonal: float | None) -> np.ndarray:
    """[β_s, β_p, rates, (f, ḟ, age) × K]: one tonal in the first slot (or none)."""
    x = np.full(4 + 3 * K, np.nan)
    x[:4] = [bearing, (bearing + 180.0) % 360.0, 0.0, 0.0]
    if tonal is not None:
        x[4], x[5] = tonal, 0.0
    return x


def _track(tid: int, t0: float, t1: float, bearing: float, tonal: float | None,
           last_hit: float | None = None, deleted: bool = True) -> Track:
    """Points every 2 s over [t0, t1], measured up to ``last_hit`` (default t1), coasted
    after it; deleted at its last point when ``deleted``."""
    last_hit = t1 if last_hit is None else last_hit
    tr = Track(tid, _state(bearing, tonal), np.eye(4 + 3 * K), t0)
    for k, t in enumerate(np.arange(t0, t1 + 1e-9, 2.0)):
        hit = t <= last_hit
        tr.history.append(TrackPoint(float(t), _state(bearing, tonal), np.eye(4 + 3 * K),
                                     Status.CONFIRMED, k if hit else -1))
        tr.hits.append(bool(hit))
    if deleted:
        tr.history[-1].status = tr.status = Status.DELETED
    else:
        tr.status = Status.CONFIRMED
    return tr


def _join(tracks):
    return stitch_by_tonals(tracks, K, reid_s=120.0, reid_hz=1.0, reid_deg=20.0)


def test_a_track_after_a_gap_continues_the_one_with_its_tonal():
    a = _track(0, 0.0, 100.0, 40.0, 441.0)
    b = _track(1, 160.0, 300.0, 45.0, 441.3, deleted=False)
    (joined,) = _join([a, b])
    t = [p.time for p in joined.history]
    assert joined.id == 0 and t[0] == 0.0 and t[-1] == 300.0 and np.all(np.diff(t) > 0)
    assert joined.status is Status.CONFIRMED and len(joined.hits) == len(joined.history)


def test_a_track_born_while_the_lost_one_coasts_continues_it():
    """A lost its source at 100 s and coasted to 130 s (deleted); B took the source's lines
    from 102 s: B continues A, and A's coasted points from 102 s on are dropped."""
    a = _track(0, 0.0, 130.0, 40.0, 441.0, last_hit=100.0)
    b = _track(1, 102.0, 300.0, 47.0, 441.2, deleted=False)
    (joined,) = _join([a, b])
    t = np.array([p.time for p in joined.history])
    meas = np.array([p.meas for p in joined.history])
    assert np.all(np.diff(t) > 0) and t[0] == 0.0 and t[-1] == 300.0
    assert np.all(meas >= 0)                       # no coasted point of A is left
    assert np.sum(t >= 102.0) == len(b.history)
    assert all(p.status is not Status.DELETED for p in joined.history)


@pytest.mark.parametrize("case", ["other tonal", "measured after the start", "far bearing",
                                  "too late", "still alive"])
def test_no_join_without_every_condition(case):
    a = _track(0, 0.0, 130.0, 40.0, 441.0, last_hit=100.0, deleted=case != "still alive")
    b_bearing, b_tonal, b_start = 47.0, 441.2, 102.0
    if case == "other tonal":
        b_tonal = 589.0
    elif case == "measured after the start":
        a = _track(0, 0.0, 130.0, 40.0, 441.0, last_hit=110.0)
    elif case == "far bearing":
        b_bearing = 75.0
    elif case == "too late":
        b_start = 240.0
    b = _track(1, b_start, 300.0, b_bearing, b_tonal, deleted=False)
    assert len(_join([a, b])) == 2
