"""Bearing and received frequency of a tonal: a new measurement type in one file.

State: the relative state of the L-R paper eq. (1) with the tonal's rest frequency appended,
X = [x, y, ẋ, ẏ, f0] (m, m/s, Hz). With r = |(x, y)| and the range rate
ṙ = (x ẋ + y ẏ) / r (positive opening),

    h(X) = [atan2(x, y), f0 (1 − ṙ / c)]                      (L-R eq. (7); Doppler shift of a
                                                                source moving away at ṙ ≪ c)

and the Jacobian

    ∂β/∂(x, y) = [y, −x] / r²,
    ∂f/∂(x, y) = −(f0 / c) (v − ṙ p / r)ᵀ / r,   ∂f/∂(ẋ, ẏ) = −(f0 / c) pᵀ / r,
    ∂f/∂f0 = 1 − ṙ / c,

with p = (x, y), v = (ẋ, ẏ) and c the sound speed. Noise N(0, diag(σβ², σf²)).

:class:`ToneConstantVelocity` is the motion of that state: constant velocity on [x, y, ẋ, ẏ]
(L-R eqs. (2)-(4)) and a rest frequency that drifts as a random walk of intensity ``q_f``
(Hz²/s). Nothing else in the package knows this model: the filters (EKF, UKF, CKF, GHF, the
RPF's generic likelihood), the hypothesis bank (:mod:`arrayproc.track.manage.bank`) and, through
the base class's stacked defaults and :class:`~arrayproc.track.models.frame.ObserverRelative`,
the multi-target manager all reach it through the
:class:`~arrayproc.track.models.base.MeasurementModel` / ``MotionModel`` interfaces
(``tests/track/models/test_bearing_frequency.py`` runs it in both trackers).
"""

from __future__ import annotations

import math

import numpy as np

from arrayproc.track.base import Param
from arrayproc.track.models import _kernels as km
from arrayproc.track.models.base import MeasurementModel, MotionModel
from arrayproc.track.models.motion import ConstantVelocity
from arrayproc.track.state import Context

__all__ = ["BearingFrequency", "ToneConstantVelocity"]


def _positive(v: float) -> str | None:
    return None if v > 0 else "must be > 0"


class BearingFrequency(MeasurementModel):
    """z = [bearing (rad), received frequency (Hz)] of state [x, y, ẋ, ẏ, f0]."""

    name = "bearing_frequency"
    angular = (True, False)
    params = {"sigma_deg": Param("float", 1.0, "bearing noise σβ, deg", check=_positive),
              "sigma_hz": Param("float", 0.05, "frequency noise σf, Hz", check=_positive),
              "sound_speed": Param("float", 1500.0, "sound speed c, m/s", check=_positive)}

    def _setup(self) -> None:
        s = math.radians(self.sigma_deg)
        self._R = np.diag([s * s, self.sigma_hz ** 2])

    def function_points(self, X, ctx, out) -> None:
        X = np.asarray(X, float)
        r = np.maximum(np.hypot(X[:, 0], X[:, 1]), 1e-9)
        rdot = (X[:, 0] * X[:, 2] + X[:, 1] * X[:, 3]) / r
        out[:, 0] = np.arctan2(X[:, 0], X[:, 1])
        out[:, 1] = X[:, 4] * (1.0 - rdot / self.sound_speed)

    def jacobian(self, x: np.ndarray, ctx: Context | None = None) -> np.ndarray:
        px, py, vx, vy, f0 = (float(v) for v in np.asarray(x, float)[:5])
        r2 = max(px * px + py * py, 1e-18)
        r = math.sqrt(r2)
        rdot = (px * vx + py * vy) / r
        k = -f0 / self.sound_speed
        H = np.zeros((2, np.size(x)))
        H[0, 0], H[0, 1] = py / r2, -px / r2
        H[1, 0] = k * (vx - rdot * px / r) / r
        H[1, 1] = k * (vy - rdot * py / r) / r
        H[1, 2], H[1, 3] = k * px / r, k * py / r
        H[1, 4] = 1.0 - rdot / self.sound_speed
        return H

    def covariance(self, ctx: Context | None = None) -> np.ndarray:
        return self._R


class ToneConstantVelocity(MotionModel):
    """Constant velocity on [x, y, ẋ, ẏ] (L-R eqs. (2)-(4), ``q1`` m²/s³) and a rest
    frequency f0 with random-walk intensity ``q_f`` (Hz²/s): F = diag(F_cv, 1),
    Q = diag(Q_cv, q_f Δt)."""

    name = "cv_tone"
    ndim = 5
    linear = True
    params = {"q1": Param("float", 1e-4, "acceleration noise intensity, m²/s³",
                          check=lambda v: None if v >= 0 else "must be >= 0"),
              "q_f": Param("float", 1e-6, "rest-frequency random-walk intensity, Hz²/s",
                           check=lambda v: None if v >= 0 else "must be >= 0")}

    def _setup(self) -> None:
        self._cv = ConstantVelocity(q1=self.q1)

    def function_points(self, X, dt, ctx, out) -> None:
        km.cv_propagate_points(np.ascontiguousarray(X[:, :4]), float(dt), ctx.own_prev,
                               ctx.own, out[:, :4])
        out[:, 4] = X[:, 4]

    def jacobian(self, x: np.ndarray, dt: float, ctx: Context | None = None) -> np.ndarray:
        F = np.eye(5)
        F[:4, :4] = self._cv.jacobian(x, dt, ctx)
        return F

    def covariance(self, dt: float) -> np.ndarray:
        Q = np.zeros((5, 5))
        Q[:4, :4] = self._cv.covariance(dt)
        Q[4, 4] = self.q_f * abs(float(dt))
        return Q

    def transition_stacked(self, dt: np.ndarray) -> np.ndarray:
        dt = np.asarray(dt, float).reshape(-1)
        F = np.broadcast_to(np.eye(5), (dt.size, 5, 5)).copy()
        F[:, :4, :4] = self._cv.transition_stacked(dt)
        return F

    def covariance_stacked(self, dt: np.ndarray) -> np.ndarray:
        dt = np.asarray(dt, float).reshape(-1)
        Q = np.zeros((dt.size, 5, 5))
        Q[:, :4, :4] = self._cv.covariance_stacked(dt)
        Q[:, 4, 4] = self.q_f * np.abs(dt)
        return Q
