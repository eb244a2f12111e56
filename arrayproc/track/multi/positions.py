"""Compact-array position fixes tracked in 3-D: the Kalman filter (the EKF on a linear model)
with each row's covariance."""

from __future__ import annotations

from typing import Any

import numpy as np

from arrayproc.track.filters.stacked import StackedEKF
from arrayproc.track.manage.manager import TrackManager
from arrayproc.track.models.motion import ConstantVelocity
from arrayproc.track.models.position import Position
from arrayproc.track.multi.compose import compose_manager
from arrayproc.track.state import Context

__all__ = ["positions_manager"]

def positions_manager(cfg: dict[str, Any]) -> TrackManager:
    """Track manager for ``positions``: 3-D CV Kalman filter with each row's covariance (the
    scan context)."""
    pc = cfg["positions"]
    filt = StackedEKF(ConstantVelocity(q1=float(pc["q"]), axes=3), Position(axes=3))
    sv = float(pc["sigma_speed_mps"])

    def init(Z: np.ndarray, t: float, ctx: Context, j: int) -> tuple[np.ndarray, np.ndarray]:
        P = np.zeros((6, 6))
        P[:3, :3] = ctx.meas_cov[j]
        P[3:, 3:] = sv * sv * np.eye(3)
        return np.r_[Z[j], 0.0, 0.0, 0.0], P

    return compose_manager(cfg, filt, init, (0, 1, 2))
