"""Plane kinematics shared by the simulator and the trackers.

Conventions (docs/architecture.md): world frame x = east, y = north (m); a *true bearing* or a
*course* is the angle clockwise from north, ``atan2(dx, dy)``. Angles are degrees at every
public interface and radians inside.

A :class:`Trajectory` is piecewise: segments of constant speed and constant turn rate, so both
straight legs and the papers' coordinated turns (observer course 140° turning to 20° between
13 and 17 min) have exact closed-form positions.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from arrayproc.errors import ConfigError

# the angle helpers live in geo.angles; re-exported here for existing imports
from arrayproc.geo.angles import interp_angle_deg, true_bearing, wrap_180, wrap_pi

__all__ = ["KNOT", "Leg", "Trajectory", "course_to_velocity", "interp_angle_deg",
           "true_bearing", "wrap_180", "wrap_pi"]

KNOT = 1852.0 / 3600.0  # m/s per knot


def course_to_velocity(course_deg: np.ndarray | float, speed: np.ndarray | float) -> np.ndarray:
    """Velocity (vx east, vy north), m/s, of a course (deg true) and speed (m/s); (..., 2)."""
    c = np.deg2rad(course_deg)
    return np.stack(np.broadcast_arrays(speed * np.sin(c), speed * np.cos(c)), axis=-1)


@dataclass(frozen=True)
class Leg:
    """Constant speed (m/s) and turn rate (deg/s, > 0 clockwise) for ``duration`` s."""

    duration: float
    speed: float
    turn_rate: float = 0.0
    course_jump: float = 0.0  # deg, an instant course change at the segment's start


class Trajectory:
    """A piecewise constant-speed, constant-turn-rate track in the world frame.

    Parameters
    ----------
    start : (2,) array_like
        Position (x east, y north) in m at ``t0``.
    course : float
        Initial course, deg true.
    segments : sequence of Leg
        Consecutive segments; after the last one the final state is held (straight line at the
        last speed and course).
    t0 : float
        Time (s) of ``start``.
    """

    def __init__(self, start: Sequence[float], course: float, segments: Sequence[Leg],
                 t0: float = 0.0) -> None:
        self.start = np.asarray(start, dtype=float).reshape(2)
        self.course0 = float(course)
        self.segments = list(segments)
        self.t0 = float(t0)
        # State at each segment boundary: time, position, course (deg).
        times, pos, crs = [self.t0], [self.start.copy()], [self.course0]
        for s in self.segments:
            p, c = self._advance(pos[-1], crs[-1] + s.course_jump, s.speed, s.turn_rate,
                                 s.duration)
            times.append(times[-1] + s.duration)
            pos.append(p)
            crs.append(c)
        self._tb = np.array(times)
        self._pb = np.array(pos)
        self._cb = np.array(crs)

    @staticmethod
    def _advance(p0: np.ndarray, c0_deg: float, v: float, rate_deg: float, dt):
        """Closed-form position and course after ``dt`` s of a constant-rate turn (or a line)."""
        dt = np.asarray(dt, dtype=float)
        c0 = np.deg2rad(c0_deg)
        w = np.deg2rad(rate_deg)
        if abs(w) < 1e-12:
            dx = v * dt * np.sin(c0)
            dy = v * dt * np.cos(c0)
        else:
            c1 = c0 + w * dt
            dx = v / w * (np.cos(c0) - np.cos(c1))
            dy = v / w * (np.sin(c1) - np.sin(c0))
        p = np.stack([p0[0] + dx, p0[1] + dy], axis=-1)
        return p, np.mod(c0_deg + rate_deg * dt, 360.0)

    @property
    def t_end(self) -> float:
        return float(self._tb[-1])

    def state(self, t: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Position (n, 2) m, velocity (n, 2) m/s and course (n,) deg true at times ``t`` (s)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        pos = np.empty((t.size, 2))
        crs = np.empty(t.size)
        spd = np.empty(t.size)
        seg = np.clip(np.searchsorted(self._tb, t, side="right") - 1, 0, len(self.segments))
        for k in np.unique(seg):
            m = seg == k
            if k < len(self.segments):
                s = self.segments[k]
                v, w, jump = s.speed, s.turn_rate, s.course_jump
            else:  # hold the last state: straight on at the last speed
                v = self.segments[-1].speed if self.segments else 0.0
                w, jump = 0.0, 0.0
            dt = t[m] - self._tb[k]
            p, c = self._advance(self._pb[k], self._cb[k] + jump, v, w, dt)
            pos[m], crs[m], spd[m] = p, c, v
        vel = course_to_velocity(crs, spd)
        return pos, vel, crs

    @classmethod
    def from_legs(cls, start: Sequence[float], legs: Sequence[Mapping], t0: float = 0.0,
                  course: float | None = None) -> Trajectory:
        """Build from legs, each a mapping with ``course`` (deg), ``speed`` (m/s), ``duration`` (s)
        and optionally ``turn_rate`` (deg/s, > 0) and ``turn`` ("port", "starboard" or
        "shortest", default).

        A leg whose course differs from the current one starts with a coordinated turn at
        ``turn_rate`` (an instant change when it is absent or 0); the turn's time counts within
        the leg's duration. The papers' observer — 5 kn on 140° for 13 min, then turning to 20°
        at 30°/min, arriving at 17 min — is
        ``[{course=140, speed=5*KNOT, duration=780}, {course=20, speed=5*KNOT, duration=1020,
        turn_rate=0.5}]``.
        """
        if not legs:
            raise ConfigError("trajectory: at least one leg is required")
        segments: list[Leg] = []
        c0 = float(legs[0]["course"] if course is None else course)
        cur = c0
        for i, leg in enumerate(legs):
            try:
                target = float(leg["course"])
                speed = float(leg["speed"])
                duration = float(leg["duration"])
            except KeyError as e:
                raise ConfigError(f"trajectory leg {i}: missing key {e.args[0]!r}") from None
            if duration < 0 or speed < 0:
                raise ConfigError(f"trajectory leg {i}: speed and duration must be >= 0")
            rate = float(leg.get("turn_rate", 0.0))
            delta = float(wrap_180(target - cur))
            side = leg.get("turn", "shortest")
            if side == "starboard" and delta < 0:
                delta += 360.0
            elif side == "port" and delta > 0:
                delta -= 360.0
            elif side not in ("shortest", "port", "starboard"):
                raise ConfigError(f"trajectory leg {i}: turn must be port, starboard or shortest")
            t_turn, jump = 0.0, 0.0
            if abs(delta) > 1e-12 and rate > 0:
                t_turn = abs(delta) / rate
                if t_turn > duration + 1e-9:
                    raise ConfigError(
                        f"trajectory leg {i}: the turn needs {t_turn:.1f} s, longer than the leg")
                segments.append(Leg(t_turn, speed, float(np.sign(delta)) * rate))
            elif abs(delta) > 1e-12:
                jump = delta  # instant course change at the start of the straight part
            segments.append(Leg(duration - t_turn, speed, 0.0, jump))
            cur = target
        return cls(start, c0, segments, t0)

    @classmethod
    def static(cls, position: Sequence[float] = (0.0, 0.0), heading: float = 0.0) -> Trajectory:
        """A fixed point with a fixed heading (deg)."""
        return cls(position, heading, [])
