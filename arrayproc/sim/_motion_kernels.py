"""Closed-form evaluation of piecewise constant-turn trajectories at many times (numba).

The same kinematics as :meth:`arrayproc.geo.kinematics.Trajectory.state` (and tested against it),
for the simulator's per-sample evaluations: segment k starts at time ``tb[k]`` at position
``p0[k]`` (m) with course ``c0[k]`` (deg) and keeps speed ``v[k]`` (m/s) and turn rate ``w[k]``
(deg/s, clockwise positive). Times before ``tb[0]`` extend segment 0 backwards; after the
last boundary the final row (turn rate 0) holds.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def evaluate(t: np.ndarray, tb: np.ndarray, p0: np.ndarray, c0: np.ndarray, v: np.ndarray,
             w: np.ndarray, pos: np.ndarray, vel: np.ndarray, acc: np.ndarray,
             course: np.ndarray, rate: np.ndarray) -> None:
    """Fill pos/vel/acc (n, 2), course (n,) deg in [0, 360) and rate (n,) rad/s at times t."""
    nseg = tb.shape[0]
    d2r = math.pi / 180.0
    k = 0
    for i in range(t.shape[0]):
        ti = t[i]
        # segments are few and times mostly increasing: walk from the last one
        while k + 1 < nseg and ti >= tb[k + 1]:
            k += 1
        while k > 0 and ti < tb[k]:
            k -= 1
        dt = ti - tb[k]
        ca = c0[k] * d2r
        wr = w[k] * d2r
        sp = v[k]
        if abs(wr) < 1e-12:
            dx = sp * dt * math.sin(ca)
            dy = sp * dt * math.cos(ca)
            cb = ca
        else:
            cb = ca + wr * dt
            dx = sp / wr * (math.cos(ca) - math.cos(cb))
            dy = sp / wr * (math.sin(cb) - math.sin(ca))
        pos[i, 0] = p0[k, 0] + dx
        pos[i, 1] = p0[k, 1] + dy
        sb = math.sin(cb)
        cs = math.cos(cb)
        vel[i, 0] = sp * sb
        vel[i, 1] = sp * cs
        acc[i, 0] = sp * wr * cs
        acc[i, 1] = -sp * wr * sb
        crs = (c0[k] + w[k] * dt) % 360.0
        course[i] = crs
        rate[i] = wr
