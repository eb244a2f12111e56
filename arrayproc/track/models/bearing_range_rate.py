"""Bearing, range and range-rate measurement of a 2-D constant-velocity target — the active
sonar's ``contacts``.

State: the observer-relative state X = [x, y, ẋ, ẏ] of the L-R paper eq. (1) (m, m/s, x east,
y north; the multi-target manager's world-frame tracks reach it through
:class:`~arrayproc.track.models.frame.ObserverRelative`). With d = X[:2], δv = X[2:4],
r = |d|:

    h(X) = [atan2(d_x, d_y), r, (d · δv) / r]                (bearing clockwise from north,
                                                              range, range rate positive opening)

and the Jacobian

    ∂β/∂(x, y) = [d_y, −d_x] / r²,  ∂r/∂(x, y) = dᵀ / r,
    ∂ṙ/∂(x, y) = (δv − ṙ d / r)ᵀ / r,  ∂ṙ/∂(ẋ, ẏ) = dᵀ / r

(Bar-Shalom, Li & Kirubarajan 2001, sec. 10.3; the same model as Stone Soup's
``CartesianToBearingRangeRate2D`` with the bearing measured from north). Radians inside,
degrees in the configuration (:meth:`BearingRangeRate.from_degrees`).
"""

from __future__ import annotations

import math

import numpy as np

from arrayproc.track.base import Param
from arrayproc.track.models.base import MeasurementModel
from arrayproc.track.state import Context

__all__ = ["BearingRangeRate"]


def _positive(v: float) -> str | None:
    return None if v > 0 else "must be a positive number"


class BearingRangeRate(MeasurementModel):
    """z = [bearing (rad), range (m), range rate (m/s)] + w, w ~ N(0, diag(σ_β², σ_r², σ_ṙ²))."""

    name = "bearing_range_rate"
    angular = (True, False, False)
    state_rows = 4
    params = {"sigma_bearing": Param("float", doc="bearing noise σ_β, rad", check=_positive),
              "sigma_range": Param("float", doc="range noise σ_r, m", check=_positive),
              "sigma_range_rate": Param("float", doc="range-rate noise σ_ṙ, m/s",
                                        check=_positive)}

    def _setup(self) -> None:
        self._R = np.diag([self.sigma_bearing ** 2, self.sigma_range ** 2,
                           self.sigma_range_rate ** 2])

    @classmethod
    def from_degrees(cls, sigma_bearing_deg: float, sigma_range_m: float,
                     sigma_range_rate_mps: float) -> BearingRangeRate:
        """Build from σ_β in degrees, σ_r in m, σ_ṙ in m/s."""
        return cls(sigma_bearing=math.radians(sigma_bearing_deg),
                   sigma_range=float(sigma_range_m),
                   sigma_range_rate=float(sigma_range_rate_mps))

    @staticmethod
    def _geometry(X: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        X = np.atleast_2d(np.asarray(X, float))
        d = X[:, :2]
        dv = X[:, 2:4]
        r = np.maximum(np.hypot(d[:, 0], d[:, 1]), 1e-9)
        return d, dv, r

    def function_stacked(self, X: np.ndarray, ctx: Context | None = None) -> np.ndarray:
        """Predicted measurements (n, 3) of relative states X (n, ≥4)."""
        d, dv, r = self._geometry(X)
        return np.stack([np.arctan2(d[:, 0], d[:, 1]), r, np.einsum("ni,ni->n", d, dv) / r],
                        axis=1)

    def jacobian_stacked(self, X: np.ndarray, ctx: Context | None = None) -> np.ndarray:
        """∂h/∂X (n, 3, d)."""
        X = np.atleast_2d(np.asarray(X, float))
        d, dv, r = self._geometry(X)
        rr = np.einsum("ni,ni->n", d, dv) / r
        J = np.zeros((d.shape[0], 3, X.shape[1]))
        J[:, 0, 0] = d[:, 1] / r ** 2
        J[:, 0, 1] = -d[:, 0] / r ** 2
        J[:, 1, :2] = d / r[:, None]
        J[:, 2, :2] = (dv - (rr / r)[:, None] * d) / r[:, None]
        J[:, 2, 2:4] = d / r[:, None]
        return J

    def function_points(self, X, ctx, out) -> None:
        out[:] = self.function_stacked(X, ctx)

    def jacobian(self, x: np.ndarray, ctx: Context | None = None) -> np.ndarray:
        return self.jacobian_stacked(np.asarray(x, float)[None], ctx)[0]

    def covariance(self, ctx: Context | None = None) -> np.ndarray:
        """R (3, 3) = diag(σ_β², σ_r², σ_ṙ²)."""
        return self._R

    def noise_stacked(self, Z: np.ndarray, ctx: Context | None) -> np.ndarray:
        return self._R

    def inverse(self, z: np.ndarray, own: np.ndarray, sigma_speed: float
                ) -> tuple[np.ndarray, np.ndarray]:
        """One-point initiation in world coordinates from z = [β, r, ṙ] seen by the observer
        ``own`` [x, y, ẋ, ẏ]: position o + r u(β), velocity ẋ_o + ṙ u + 0·t with the
        unobserved tangential speed ~ N(0, σ_speed²) (m/s); the covariance linearises the
        polar noise.

        Returns
        -------
        x : ndarray (4,)
            State, m and m/s.
        P : ndarray (4, 4)
            Covariance.
        """
        b, r, rr = (float(v) for v in np.asarray(z, float).reshape(3))
        o = np.asarray(own, float).reshape(4)
        u = np.array([math.sin(b), math.cos(b)])
        tn = np.array([math.cos(b), -math.sin(b)])
        x = np.r_[o[:2] + r * u, o[2:] + rr * u]
        P = np.zeros((4, 4))
        P[:2, :2] = self.sigma_range ** 2 * np.outer(u, u) \
            + (r * self.sigma_bearing) ** 2 * np.outer(tn, tn)
        P[2:, 2:] = self.sigma_range_rate ** 2 * np.outer(u, u) \
            + float(sigma_speed) ** 2 * np.outer(tn, tn)
        return x, P
