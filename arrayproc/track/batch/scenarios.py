"""Geometry of the thesis's batch-TMA scenarios (section 3.3.3) and of the compact-array test.

- Fig. 3.18 (precision, fig. 3.19): source initial position (2000 m, 1000 m). The figure itself
  is not in the text; our reading of the ownship track is that of fig. 3.20 (the thesis's
  "typical TMA scenario"): two five-minute straight legs separated by a 45° turn. We take the
  ownship at 3 m/s, course 0° then 315° (turn at 300 s), and the source at 3 m/s on course
  0° (:data:`FIG_3_18_SOURCE`), snapshots every 5 s (121 snapshots): the source stays on the
  starboard side, 63°-109° off the bow, at 2.2-2.9 km.
- Array: 128 hydrophones spaced 0.36 m (thesis 3.3.3.1), straight, trailing the reference
  hydrophone (hydrophone 1, at the ownship position) along the ownship heading.
- Fig. 3.22 (parallel tracks): ownship and source on parallel tracks for ten minutes at the
  same course and speed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["FIG_3_18_SOURCE", "ENDFIRE_SOURCE", "OwnTrack", "turn_track", "parallel_track",
           "endfire_turn_track", "line_elements", "source_positions"]


#: Source state [x, y, vx, vy] (m, m/s) at the start of the fig. 3.18 scenario.
FIG_3_18_SOURCE = np.array([2000.0, 1000.0, 0.0, 3.0])


#: Source of :func:`endfire_turn_track`: 3.6 km on bearing 025 at the start, 3 m/s on course
#: 300 (m, m/s); the ownship's turn carries it from the starboard bow through forward
#: end-fire to the port side.
ENDFIRE_SOURCE = np.array([3600.0 * np.sin(np.deg2rad(25.0)), 3600.0 * np.cos(np.deg2rad(25.0)),
                           3.0 * np.sin(np.deg2rad(300.0)), 3.0 * np.cos(np.deg2rad(300.0))])


@dataclass(frozen=True)
class OwnTrack:
    """Ownship samples: ``time`` (B,) s, ``position`` (B, 2) m, ``heading`` (B,) rad."""

    time: np.ndarray
    position: np.ndarray
    heading: np.ndarray


def _legs(times: np.ndarray, courses_deg: list[float], durations: list[float],
          speed: float) -> OwnTrack:
    pos = np.zeros((times.size, 2))
    hd = np.zeros(times.size)
    start = np.zeros(2)
    t_start = 0.0
    for c, d in zip(courses_deg, durations, strict=True):
        cr = np.deg2rad(c)
        v = speed * np.array([np.sin(cr), np.cos(cr)])
        sel = (times >= t_start) & (times <= t_start + d + 1e-9)
        pos[sel] = start + (times[sel] - t_start)[:, None] * v
        hd[sel] = cr
        start = start + d * v
        t_start += d
    return OwnTrack(times, pos, hd)


def turn_track(duration: float = 600.0, dt: float = 5.0, speed: float = 3.0,
               courses_deg: tuple[float, float] = (0.0, 315.0)) -> OwnTrack:
    """Two straight legs of ``duration/2`` separated by an instant turn (thesis fig. 3.20).

    Parameters
    ----------
    duration, dt : float
        Total duration and snapshot interval (s).
    speed : float
        m/s.
    courses_deg : (float, float)
        Courses of the two legs (deg clockwise from north).

    Returns
    -------
    OwnTrack
    """
    t = np.arange(0.0, duration + 1e-9, dt)
    return _legs(t, list(courses_deg), [duration / 2, duration / 2], speed)


def parallel_track(duration: float = 600.0, dt: float = 5.0, speed: float = 3.0,
                   course_deg: float = 0.0) -> OwnTrack:
    """One straight leg (thesis fig. 3.22: ownship and source on parallel tracks).

    Parameters
    ----------
    duration, dt, speed, course_deg : float
        s, s, m/s, deg.

    Returns
    -------
    OwnTrack
    """
    t = np.arange(0.0, duration + 1e-9, dt)
    return _legs(t, [course_deg], [duration], speed)


def line_elements(track: OwnTrack, n: int = 128, spacing: float = 0.36) -> np.ndarray:
    """World positions (B, n, 2) of a straight line array trailing the ownship position.

    Element 0 (the reference, the thesis's hydrophone 1) is at the ownship position; element
    k is ``k·spacing`` behind it along the heading.
    """
    back = -np.arange(n) * spacing
    u = np.stack([np.sin(track.heading), np.cos(track.heading)], -1)      # (B, 2)
    return track.position[:, None, :] + back[None, :, None] * u[:, None, :]


def source_positions(state: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """Positions (B, 2) of a constant-velocity source with state [x, y, vx, vy] at τ = 0."""
    s = np.asarray(state, float)
    return s[None, :2] + np.asarray(tau, float)[:, None] * s[None, 2:]


def endfire_turn_track(n: int = 126, dt: float = 5.0, speed: float = 5 * 1852.0 / 3600.0,
                       turn_at: float = 300.0, turn_deg: float = 45.0,
                       rate_deg_s: float = 1.0) -> tuple[OwnTrack, np.ndarray]:
    """Ownship north at 5 kn, then a turn to starboard at ``rate_deg_s`` to ``turn_deg``, and
    on: the end-fire-crossing check of the line-array TMA (with :data:`ENDFIRE_SOURCE`).

    Positions are integrated at 0.1 s. Returns the track at ``n`` times ``dt`` apart and the
    ownship velocity (n, 2) m/s.
    """
    fine = np.arange(0.0, (n - 1) * dt + 0.05, 0.1)
    hd = np.deg2rad(np.clip((fine - turn_at) * rate_deg_s, 0.0, turn_deg))
    v = speed * np.stack([np.sin(hd), np.cos(hd)], axis=1)
    pos = np.concatenate([[[0.0, 0.0]], np.cumsum(v[:-1] * 0.1, axis=0)])
    t = np.arange(n) * dt
    idx = np.rint(t / 0.1).astype(int)
    return OwnTrack(t, pos[idx], hd[idx]), v[idx]
