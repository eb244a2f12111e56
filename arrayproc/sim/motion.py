"""Exact 3-D kinematics of everything that moves in a scenario: positions, velocities and
accelerations at arbitrary times, from :class:`arrayproc.kinematics.Trajectory`.

World frame x east, y north, z down (m). Every mover exposes ``state3(t) -> (pos, vel, acc)``,
each of shape (n, 3), evaluated in closed form (straight legs and constant-rate turns), also
before the scenario's start (the first leg is extended backwards), which retarded times need.
"""

from __future__ import annotations

import numpy as np

from ..kinematics import Trajectory


def _turn_rate(traj: Trajectory, t: np.ndarray) -> np.ndarray:
    """Turn rate (rad/s) of the segment active at each time (0 before/after the segments)."""
    if not traj.segments:
        return np.zeros(t.shape)
    tb = traj.t0 + np.concatenate([[0.0], np.cumsum([s.duration for s in traj.segments])])
    seg = np.searchsorted(tb, t, side="right") - 1
    rates = np.array([np.deg2rad(s.turn_rate) for s in traj.segments] + [0.0])
    # before t0 the first segment is extended backwards with its own turn rate
    return rates[np.clip(seg, 0, len(traj.segments))]


class TrackMover:
    """A point following a :class:`Trajectory` at a constant depth (m)."""

    def __init__(self, traj: Trajectory, depth: float, lead: float = 0.0) -> None:
        self.traj = traj
        self.depth = float(depth)
        self.lead = float(lead)  # s: the point is where the track is ``lead`` s later

    def state3(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        t = np.atleast_1d(np.asarray(t, dtype=float)) + self.lead
        p2, v2, crs = self.traj.state(t)
        w = _turn_rate(self.traj, t)
        c = np.deg2rad(crs)
        spd = np.hypot(v2[:, 0], v2[:, 1])
        n = t.size
        pos = np.empty((n, 3))
        vel = np.zeros((n, 3))
        acc = np.zeros((n, 3))
        pos[:, :2] = p2
        pos[:, 2] = self.depth
        vel[:, :2] = v2
        acc[:, 0] = spd * w * np.cos(c)
        acc[:, 1] = -spd * w * np.sin(c)
        return pos, vel, acc

    def course(self, t: np.ndarray) -> np.ndarray:
        """Course (deg true) at times t."""
        return self.traj.state(np.atleast_1d(np.asarray(t, float)) + self.lead)[2]


class FixedMover:
    """A static point (x, y, z)."""

    def __init__(self, position: np.ndarray) -> None:
        self.position = np.asarray(position, dtype=float).reshape(3)

    def state3(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        n = np.atleast_1d(np.asarray(t)).size
        return np.tile(self.position, (n, 1)), np.zeros((n, 3)), np.zeros((n, 3))


class BodyOffsetMover:
    """A point rigidly attached to the array's body frame (e.g. the projector).

    ``offset`` (x forward, y starboard, z down) in m relative to the array reference point,
    which follows ``ownship`` (a :class:`TrackMover`, heading = course).
    """

    def __init__(self, ownship: TrackMover, offset: np.ndarray) -> None:
        self.own = ownship
        self.offset = np.asarray(offset, dtype=float).reshape(3)

    def state3(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        t = np.atleast_1d(np.asarray(t, dtype=float))
        p, v, a = self.own.state3(t)
        h = np.deg2rad(self.own.course(t))
        w = _turn_rate(self.own.traj, t + self.own.lead)
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
