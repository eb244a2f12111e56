"""Bearing measurement, L-R paper eq. (7): γ(X) = atan2(x, y), clockwise from north.

The relative position [x, y] of the state gives the bearing from the observer; the noise is
N(0, σθ²). Also the bearing helpers in degrees and the port/starboard split of a line array.
"""

from __future__ import annotations

import math

import numpy as np

from arrayproc.geo.angles import wrap_pi
from arrayproc.track.base import Param
from arrayproc.track.models import _kernels as km
from arrayproc.track.models.base import MeasurementModel
from arrayproc.track.state import Context

__all__ = ["Bearing", "bearing_rad", "bearing_deg", "port_starboard", "bearing_sigma_mean",
           "bearing_residual"]


def _positive(v: float) -> str | None:
    return None if v > 0 else "must be > 0"


class Bearing(MeasurementModel):
    """z = γ(X) + w, w ~ N(0, σθ²) (eq. (7)); ``sigma_deg`` is σθ in degrees."""

    name = "bearing"
    state_rows = 2
    angular = (True,)
    params = {"sigma_deg": Param("float", 1.5, "bearing noise σθ, deg", check=_positive)}

    def _setup(self) -> None:
        self.sigma = math.radians(self.sigma_deg)
        self._R = np.array([[self.sigma * self.sigma]])

    def function_points(self, X, ctx, out) -> None:
        km.bearing_points(X, out)

    def jacobian(self, x: np.ndarray, ctx: Context | None = None) -> np.ndarray:
        H = np.empty((1, np.size(x)))
        km.bearing_jacobian(np.ascontiguousarray(x, dtype=float), H)
        return H

    def covariance(self, ctx: Context | None = None) -> np.ndarray:
        return self._R

    def loglik_particles(self, rel, z, ctx, out) -> None:
        km.bearing_loglik(rel, float(np.asarray(z).reshape(-1)[0]), self.sigma, out)

    def loglik_norm(self, ctx: Context | None = None) -> float:
        return math.log(math.sqrt(2 * math.pi) * self.sigma)

    def as_bearing(self, z, ctx) -> float:
        return float(np.asarray(z).reshape(-1)[0])

    @property
    def bearing_sigma(self) -> float:
        return self.sigma


def bearing_rad(x: np.ndarray) -> np.ndarray:
    """γ(X) = atan2(x, y), rad in [−π, π], for states of shape (..., n) (eq. (7))."""
    x = np.asarray(x, float)
    return np.arctan2(x[..., 0], x[..., 1])


def bearing_deg(x: np.ndarray) -> np.ndarray:
    """Bearing of eq. (7) in degrees clockwise from north, in [0, 360)."""
    return np.mod(np.rad2deg(bearing_rad(x)), 360.0)


def port_starboard(bearing_rad_: np.ndarray, heading_rad: np.ndarray) -> tuple[np.ndarray,
                                                                                  np.ndarray,
                                                                                  np.ndarray]:
    """Split a (true) bearing and its eq.-(8) mirror into the port and starboard members of the
    pair a line array reports.

    Parameters
    ----------
    bearing_rad_ : array_like
        True bearings, rad.
    heading_rad : array_like
        Array heading, rad.

    Returns
    -------
    port, starboard : ndarray
        The pair, rad in [−π, π).
    true_is_starboard : ndarray of bool
    """
    d = wrap_pi(np.asarray(bearing_rad_, float) - heading_rad)
    cone = np.abs(d)
    port = wrap_pi(heading_rad - cone)
    stbd = wrap_pi(heading_rad + cone)
    return port, stbd, d >= 0.0


def bearing_sigma_mean(sigmas: np.ndarray, wm: np.ndarray) -> np.ndarray:
    """Weighted mean of sigma-point bearings (rad, first column), unwrapped about the first
    point — the rule our UKF uses; a ``z_mean_fn`` for other UKF libraries (filterpy)."""
    z = np.asarray(sigmas)[:, 0]
    return np.array([wrap_pi(z[0] + np.dot(wm, wrap_pi(z - z[0])))])


def bearing_residual(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Bearing difference wrapped to [−π, π) (a ``residual_z`` for other UKF libraries)."""
    return wrap_pi(np.asarray(a) - np.asarray(b))
