"""Exact 3-D kinematics of everything that moves in a scenario: positions, velocities and
accelerations at arbitrary times, from :class:`arrayproc.geo.kinematics.Trajectory`.

World frame x east, y north, z down (m). Every mover exposes ``state3(t) -> (pos, vel, acc)``,
each of shape (n, 3), evaluated in closed form (straight legs and constant-rate turns), also
before the scenario's start (the first leg is extended backwards), which retarded times need.
"""

from __future__ import annotations

import numpy as np

from arrayproc.geo.kinematics import Trajectory
from arrayproc.sim._motion_kernels import evaluate


def segment_table(traj: Trajectory) -> tuple[np.ndarray, ...]:
    """(tb, p0, c0, v, w) of a trajectory for :func:`arrayproc.sim._motion_kernels.evaluate`:
    each segment's start time, position, course (after any instant jump), speed, turn rate,
    plus a final holding row (straight on at the last speed)."""
    segs = traj.segments
    tb = traj.t0 + np.concatenate([[0.0], np.cumsum([s.duration for s in segs])])
    p, _, c = traj.state(tb)  # state at a boundary = start of the following segment
    v = np.array([s.speed for s in segs] + [segs[-1].speed if segs else 0.0])
    w = np.array([s.turn_rate for s in segs] + [0.0])
    return (np.ascontiguousarray(tb), np.ascontiguousarray(p), np.ascontiguousarray(c), v, w)


class TrackMover:
    """A point following a :class:`Trajectory` at a constant depth (m)."""

    def __init__(self, traj: Trajectory, depth: float, lead: float = 0.0) -> None:
        self.traj = traj
        self.depth = float(depth)
        self.lead = float(lead)  # s: the point is where the track is ``lead`` s later
        self._tab = segment_table(traj)

    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, ...]:
        """pos, vel, acc (n, 3), course (n,) deg, turn rate (n,) rad/s at times t."""
        t = np.ascontiguousarray(np.atleast_1d(np.asarray(t, dtype=float)) + self.lead)
        n = t.size
        p2, v2, a2 = np.empty((n, 2)), np.empty((n, 2)), np.empty((n, 2))
        crs, rate = np.empty(n), np.empty(n)
        evaluate(t, *self._tab, p2, v2, a2, crs, rate)
        pos = np.empty((n, 3))
        pos[:, :2] = p2
        pos[:, 2] = self.depth
        vel = np.zeros((n, 3))
        vel[:, :2] = v2
        acc = np.zeros((n, 3))
        acc[:, :2] = a2
        return pos, vel, acc, crs, rate

    @property
    def is_static(self) -> bool:
        """Whether the point never moves or turns (speed and turn rate 0 throughout)."""
        return bool(np.all(self._tab[3] == 0.0) and np.all(self._tab[4] == 0.0))

    def state3(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return self.evaluate(t)[:3]

    def arc_length(self, t: np.ndarray) -> np.ndarray:
        """Distance travelled along the track since its start time (m; negative before it:
        the first leg extended backwards). Speeds are constant within segments, so this is
        piecewise linear in t."""
        tb, _, _, v, _ = self._tab
        sb = np.concatenate([[0.0], np.cumsum(v[:-1] * np.diff(tb))])
        t = np.asarray(t, float) + self.lead
        i = np.clip(np.searchsorted(tb, t, side="right") - 1, 0, tb.size - 1)
        return sb[i] + v[i] * (t - tb[i])

    def time_at_arc(self, s: np.ndarray) -> np.ndarray:
        """Inverse of :meth:`arc_length` (every segment's speed must be > 0)."""
        tb, _, _, v, _ = self._tab
        sb = np.concatenate([[0.0], np.cumsum(v[:-1] * np.diff(tb))])
        s = np.asarray(s, float)
        i = np.clip(np.searchsorted(sb, s, side="right") - 1, 0, tb.size - 1)
        return tb[i] + (s - sb[i]) / v[i] - self.lead

    def threaded(self, t: np.ndarray, body: np.ndarray, lateral: np.ndarray) -> np.ndarray:
        """World positions (n, ch, 3) of elements threaded on the track (water-pulled array).

        Element ``ch`` at body (x, y, z) sits where the reference point was (x < 0) or will
        be (x > 0) at arc length s(t) + x along the track, offset y + ``lateral[k]`` to
        starboard of the track's course there and z below it: the tow point's path as in
        the threading model. On a straight leg this is the rigid layout exactly.
        """
        t = np.asarray(t, float)
        s = self.arc_length(t)
        tn = self.time_at_arc(s[:, None] + body[None, :, 0])
        p, _, _, crs, _ = self.evaluate(tn.reshape(-1))
        h = np.deg2rad(crs).reshape(tn.shape)
        by = body[None, :, 1] + np.asarray(lateral, float)[:, None]
        out = np.empty(tn.shape + (3,))
        out[..., 0] = p[:, 0].reshape(tn.shape) + by * np.cos(h)
        out[..., 1] = p[:, 1].reshape(tn.shape) - by * np.sin(h)
        out[..., 2] = p[:, 2].reshape(tn.shape) + body[None, :, 2]
        return out

    def course(self, t: np.ndarray) -> np.ndarray:
        """Course (deg true) at times t."""
        return self.evaluate(t)[3]


class FixedMover:
    """A static point (x, y, z)."""

    is_static = True

    def __init__(self, position: np.ndarray) -> None:
        self.position = np.asarray(position, dtype=float).reshape(3)

    def state3(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        n = np.atleast_1d(np.asarray(t)).size
        return np.tile(self.position, (n, 1)), np.zeros((n, 3)), np.zeros((n, 3))


class DriftMover:
    """A point drifting at a constant velocity: x(t) = x0 + v t (drifting clutter)."""

    is_static = False

    def __init__(self, position: np.ndarray, velocity: np.ndarray) -> None:
        self.position = np.asarray(position, dtype=float).reshape(3)
        self.velocity = np.asarray(velocity, dtype=float).reshape(3)

    def state3(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        t = np.atleast_1d(np.asarray(t, dtype=float))
        return (self.position + t[:, None] * self.velocity, np.tile(self.velocity, (t.size, 1)),
                np.zeros((t.size, 3)))


class BodyOffsetMover:
    """A point rigidly attached to the array's body frame (e.g. the projector).

    ``offset`` (x forward, y starboard, z down) in m relative to the array reference point,
    which follows ``ownship`` (a :class:`TrackMover`, heading = course).
    """

    def __init__(self, ownship: TrackMover, offset: np.ndarray) -> None:
        self.own = ownship
        self.offset = np.asarray(offset, dtype=float).reshape(3)

    @property
    def is_static(self) -> bool:
        return self.own.is_static

    def state3(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        p, v, a, crs, w = self.own.evaluate(t)
        h = np.deg2rad(crs)
        bx, by, bz = self.offset
        s, c = np.sin(h), np.cos(h)
        ox = bx * s + by * c  # body_to_world rotation
        oy = bx * c - by * s
        pos = p.copy()
        pos[:, 0] += ox
        pos[:, 1] += oy
        pos[:, 2] += bz
        vel = v.copy()  # d/dt of the rotated offset: ω·(bx cos h − by sin h, −bx sin h − by cos h)
        vel[:, 0] += w * oy
        vel[:, 1] += -w * ox
        acc = a.copy()
        acc[:, 0] += -w * w * ox
        acc[:, 1] += -w * w * oy
        return pos, vel, acc
