"""Mirrored (ghost) bearing of a line array, L-R paper eq. (8): θ_g = 2h − γ(X).

A line array cannot tell a source on bearing θ from its mirror about the array axis h; this
model predicts the ghost member of the pair from the true relative state, with the array
heading h (rad) taken from the context. Its Jacobian is minus the bearing's.
"""

from __future__ import annotations

import math

import numpy as np

from arrayproc.geo.angles import wrap_pi
from arrayproc.track.base import Param
from arrayproc.track.models import _kernels as km
from arrayproc.track.models.base import MeasurementModel
from arrayproc.track.state import Context

__all__ = ["MirroredBearing", "mirror_bearing_deg"]


class MirroredBearing(MeasurementModel):
    """z = wrap(2h − γ(X)) + w, w ~ N(0, σθ²) (eq. (8)); h = ``ctx.heading``."""

    name = "mirrored_bearing"
    state_rows = 2
    angular = (True,)
    params = {"sigma_deg": Param("float", 1.5, "bearing noise σθ, deg",
                                 check=lambda v: None if v > 0 else "must be > 0")}

    def _setup(self) -> None:
        self.sigma = math.radians(self.sigma_deg)
        self._R = np.array([[self.sigma * self.sigma]])

    def function_points(self, X, ctx, out) -> None:
        km.mirrored_bearing_points(X, float(ctx.heading), out)

    def jacobian(self, x: np.ndarray, ctx: Context | None = None) -> np.ndarray:
        H = np.empty((1, np.size(x)))
        km.bearing_jacobian(np.ascontiguousarray(x, dtype=float), H)
        return -H

    def covariance(self, ctx: Context | None = None) -> np.ndarray:
        return self._R

    def loglik_particles(self, rel, z, ctx, out) -> None:
        # the ghost z is the true bearing 2h − z seen through the same noise
        km.bearing_loglik(rel, 2.0 * float(ctx.heading) - float(np.asarray(z).reshape(-1)[0]),
                          self.sigma, out)

    def loglik_norm(self, ctx: Context | None = None) -> float:
        return math.log(math.sqrt(2 * math.pi) * self.sigma)

    def as_bearing(self, z, ctx) -> float:
        return float(wrap_pi(2.0 * float(ctx.heading) - float(np.asarray(z).reshape(-1)[0])))

    @property
    def bearing_sigma(self) -> float:
        return self.sigma


def mirror_bearing_deg(bearing: np.ndarray | float, heading: np.ndarray | float) -> np.ndarray:
    """Ghost bearing θ_g = 2h − θ about the array heading h (eq. (8)).

    Parameters
    ----------
    bearing, heading : array_like
        Bearing and heading, deg.

    Returns
    -------
    ndarray
        Ghost bearing, deg in [0, 360).
    """
    return np.mod(2.0 * np.asarray(heading, float) - np.asarray(bearing, float), 360.0)
