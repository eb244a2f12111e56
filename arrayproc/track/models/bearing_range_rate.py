"""Bearing, range and range-rate measurement of a 2-D constant-velocity target from a moving
observer — the active sonar's ``contacts`` (DESIGN section 5).

State X = [x, y, ẋ, ẏ] (m, m/s, world frame, x east, y north); observer o = [x, y, ẋ, ẏ]
in the context. With d = X[:2] − o[:2], δv = X[2:] − o[2:], r = |d|:

    h(X) = [atan2(d_x, d_y), r, (d · δv) / r]                (bearing clockwise from north,
                                                              range, range rate positive opening)

and the Jacobian

    ∂β/∂(x, y) = [d_y, −d_x] / r²,  ∂r/∂(x, y) = dᵀ / r,
    ∂ṙ/∂(x, y) = (δv − ṙ d / r)ᵀ / r,  ∂ṙ/∂(ẋ, ẏ) = dᵀ / r

(Bar-Shalom, Li & Kirubarajan 2001, sec. 10.3; the same model as Stone Soup's
``CartesianToBearingRangeRate2D`` with the bearing measured from north). Radians inside,
degrees in the configuration.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from arrayproc.errors import ConfigError


@dataclass(frozen=True)
class BearingRangeRate:
    """Measurement model z = [bearing (rad), range (m), range rate (m/s)] with independent
    noise σ_β (rad), σ_r (m), σ_ṙ (m/s). The context of :meth:`h`, :meth:`jacobian` is the
    observer state [x, y, ẋ, ẏ] (m, m/s)."""

    sigma_bearing: float
    sigma_range: float
    sigma_range_rate: float
    dim: int = 3
    angles: tuple[int, ...] = (0,)

    def __post_init__(self) -> None:
        for k in ("sigma_bearing", "sigma_range", "sigma_range_rate"):
            v = getattr(self, k)
            if not (v > 0 and math.isfinite(v)):
                raise ConfigError(f"bearing_range_rate: {k} must be a positive number")

    @classmethod
    def from_degrees(cls, sigma_bearing_deg: float, sigma_range_m: float,
                     sigma_range_rate_mps: float) -> BearingRangeRate:
        """Build from σ_β in degrees, σ_r in m, σ_ṙ in m/s."""
        return cls(math.radians(sigma_bearing_deg), float(sigma_range_m),
                   float(sigma_range_rate_mps))

    @staticmethod
    def _geometry(X: np.ndarray, own: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        X = np.atleast_2d(np.asarray(X, float))
        o = np.asarray(own, float).reshape(4)
        d = X[:, :2] - o[:2]
        dv = X[:, 2:4] - o[2:4]
        r = np.maximum(np.hypot(d[:, 0], d[:, 1]), 1e-9)
        return d, dv, r

    def h(self, X: np.ndarray, own: np.ndarray) -> np.ndarray:
        """Predicted measurements (n, 3) of states X (n, 4) seen from observer ``own``."""
        d, dv, r = self._geometry(X, own)
        return np.stack([np.arctan2(d[:, 0], d[:, 1]), r, np.einsum("ni,ni->n", d, dv) / r],
                        axis=1)

    def jacobian(self, X: np.ndarray, own: np.ndarray) -> np.ndarray:
        """∂h/∂X (n, 3, 4)."""
        d, dv, r = self._geometry(X, own)
        rr = np.einsum("ni,ni->n", d, dv) / r
        J = np.zeros((d.shape[0], 3, 4))
        J[:, 0, 0] = d[:, 1] / r ** 2
        J[:, 0, 1] = -d[:, 0] / r ** 2
        J[:, 1, :2] = d / r[:, None]
        J[:, 2, :2] = (dv - (rr / r)[:, None] * d) / r[:, None]
        J[:, 2, 2:] = d / r[:, None]
        return J

    def noise(self, own: np.ndarray | None = None, m: int = 1) -> np.ndarray:
        """R (3, 3) = diag(σ_β², σ_r², σ_ṙ²)."""
        return np.diag([self.sigma_bearing ** 2, self.sigma_range ** 2,
                        self.sigma_range_rate ** 2])

    def inverse(self, z: np.ndarray, own: np.ndarray, sigma_speed: float
                ) -> tuple[np.ndarray, np.ndarray]:
        """One-point initiation from z = [β, r, ṙ]: position o + r u(β), velocity
        ẋ_o + ṙ u + 0·t with the unobserved tangential speed ~ N(0, σ_speed²) (m/s); the
        covariance linearises the polar noise.

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


__all__ = ["BearingRangeRate"]
