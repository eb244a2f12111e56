"""A static source in observer-relative coordinates (thesis eq. (3.40) with Φ = I), the motion
model of the recursive TDOA tracker's ``motion = "static"``."""

from __future__ import annotations

import numpy as np

from arrayproc.track.base import Param
from arrayproc.track.models.base import MotionModel
from arrayproc.track.state import Context

__all__ = ["StaticPosition"]


class StaticPosition(MotionModel):
    """A static source in relative coordinates, thesis eq. (3.40) with Φ = I on the absolute
    position: x_k = x_{k−1} + o_{k−1} − o_k (o the observer position), plus a position random
    walk of intensity ``q`` (m²/s): Q = q Δt I."""

    name = "static"
    ndim = 2
    linear = True
    params = {"q": Param("float", 0.0, "position random-walk intensity, m²/s",
                         check=lambda v: None if v >= 0 else "must be >= 0")}

    def function_points(self, X: np.ndarray, dt: float, ctx: Context,
                        out: np.ndarray) -> None:
        """Relative positions after the observer's displacement (rows of ``X``)."""
        out[:] = X + (ctx.own_prev[:2] - ctx.own[:2])[None, :]

    def jacobian(self, x: np.ndarray, dt: float, ctx: Context | None = None) -> np.ndarray:
        """Φ = I (eq. (3.40))."""
        return np.eye(2)

    def covariance(self, dt: float) -> np.ndarray:
        """q Δt I."""
        return self.q * abs(float(dt)) * np.eye(2)
