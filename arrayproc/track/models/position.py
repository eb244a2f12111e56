"""Linear measurements of the leading state components: a position fix and a line array's
cone angle.

- :class:`Position`: z = [x, y(, z)] (m), the first ``axes`` components, with each row's own
  covariance (the ``cov`` column of ``positions`` rows, the scan context's ``meas_cov``).
- :class:`ConeAngle`: z = θ (deg), the first component of a [θ, θ̇] track, with
  σ = σ_θ / max(sin θ, s_min): the beam widening towards end-fire (thesis eq. 2.9).

H is a selection [I 0], so the EKF on these models is the Kalman filter exactly
(Bar-Shalom, Li & Kirubarajan 2001, eqs. 5.2.3-9 to 5.2.3-15).
"""

from __future__ import annotations

import numpy as np

from arrayproc.track.base import Param
from arrayproc.track.models.base import MeasurementModel
from arrayproc.track.state import Context

__all__ = ["Position", "ConeAngle", "BearingDeg"]


class _Selection(MeasurementModel):
    """z = H x with H = [I_k 0]: the first k components."""

    k = 1

    def function_stacked(self, X: np.ndarray, ctx: Context | None = None) -> np.ndarray:
        return X @ self._H(X.shape[1]).T

    def jacobian_stacked(self, X: np.ndarray, ctx: Context | None = None) -> np.ndarray:
        H = self._H(X.shape[1])
        return np.broadcast_to(H, (X.shape[0],) + H.shape)

    def function_points(self, X, ctx, out) -> None:
        out[:] = self.function_stacked(X, ctx)

    def jacobian(self, x: np.ndarray, ctx: Context | None = None) -> np.ndarray:
        return self._H(np.size(x))

    def _H(self, d: int) -> np.ndarray:
        H = np.zeros((self.k, d))
        H[:, :self.k] = np.eye(self.k)
        return H


class Position(_Selection):
    """Position fix of the first ``axes`` components; R = σ² I, or with ``sigma`` = 0 each
    measurement's own from the scan context's ``meas_cov`` (m, axes, axes)."""

    name = "position"
    params = {"axes": Param("int", 3, "position axes measured",
                            check=lambda v: None if v >= 1 else "must be >= 1"),
              "sigma": Param("float", 0.0, "σ per axis, m (0: each row's covariance)",
                             check=lambda v: None if v >= 0 else "must be >= 0")}

    def _setup(self) -> None:
        self.k = self.axes
        self.angular = (False,) * self.axes

    def covariance(self, ctx: Context | None = None) -> np.ndarray:
        if self.sigma > 0:
            return self.sigma ** 2 * np.eye(self.k)
        raise NotImplementedError("position: sigma = 0, the noise is each row's "
                                  "(noise_stacked with ctx.meas_cov)")

    def noise_stacked(self, Z: np.ndarray, ctx: Context | None) -> np.ndarray:
        return self.covariance(ctx) if self.sigma > 0 else ctx.meas_cov


class ConeAngle(_Selection):
    """Cone angle θ (deg) of a [θ, θ̇] track; σ_θ at broadside widened by 1 / sin θ down to
    ``min_sin`` (thesis eq. 2.9)."""

    name = "cone_angle"
    angular = (False,)  # a cone angle lies in [0, 180] deg: no wrap
    params = {"sigma_deg": Param("float", 0.7, "cone-angle noise at broadside, deg",
                                 check=lambda v: None if v > 0 else "must be > 0"),
              "min_sin": Param("float", 0.2, "floor of sin θ in the noise widening",
                               check=lambda v: None if 0 < v <= 1 else "must be in (0, 1]")}

    def sigma(self, cone_deg: np.ndarray) -> np.ndarray:
        """σ (deg) of measurements at cone angles ``cone_deg``."""
        return self.sigma_deg / np.maximum(np.sin(np.deg2rad(cone_deg)), self.min_sin)

    def covariance(self, ctx: Context | None = None) -> np.ndarray:
        return np.array([[self.sigma_deg ** 2]])

    def noise_stacked(self, Z: np.ndarray, ctx: Context | None) -> np.ndarray:
        return (self.sigma(Z[:, 0]) ** 2)[:, None, None]


class BearingDeg(_Selection):
    """A bearing (deg) of the first component of a [β, β̇] hypothesis, residuals wrapped at
    360°; R per measurement from the context's ``meas_cov`` (the mirror sides of a line
    array's bearing tracks, whose σ widens with the cone angle, thesis eq. 2.9)."""

    name = "bearing_deg"
    angular = (True,)
    angle_period = 360.0

    def covariance(self, ctx: Context | None = None) -> np.ndarray:
        return np.asarray(ctx.meas_cov, float)

    def noise_stacked(self, Z: np.ndarray, ctx: Context | None) -> np.ndarray:
        return ctx.meas_cov
