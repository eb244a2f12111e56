"""Interfaces of motion and measurement models (Stone Soup's split: a model knows its function,
Jacobian and noise; filters know how to combine them).

A motion model maps the relative state over ``dt`` with the observer context (L-R paper
eq. (1)); a measurement model maps a relative state to a measurement vector with noise
covariance R. Measurement components flagged in ``angular`` are angles (rad): their residuals
are wrapped with :func:`arrayproc.geo.angles.wrap_pi` and the sample-point filters average them
on the circle. Adding a measurement type is one new subclass of :class:`MeasurementModel`.

Every model also has a *stacked* form for many tracks at once (X (n, d), the multi-target
manager's tracks, :mod:`arrayproc.track.filters.stacked`): ``transition_stacked`` /
``covariance_stacked`` of a linear motion model, and ``function_stacked`` /
``jacobian_stacked`` / ``noise_stacked`` of a measurement model. The measurement model's
defaults run its one-track methods row by row, so a new model reaches the multi-target
tracker without writing them; models on a hot path override them with array operations.
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from arrayproc.geo.angles import wrap_pi
from arrayproc.track.base import Component
from arrayproc.track.state import Context

__all__ = ["MotionModel", "MeasurementModel"]


class MotionModel(Component):
    """Relative-state motion model: ``function``, ``jacobian``, ``covariance``."""

    name = "motion"
    ndim: ClassVar[int] = 4
    linear: ClassVar[bool] = False  # True: function(x) = F x + u exactly (exact EKF predict)

    def function(self, x: np.ndarray, dt: float, ctx: Context) -> np.ndarray:
        """Predicted relative state after ``dt`` s (observer states in ``ctx``)."""
        out = np.empty((1, self.ndim))
        self.function_points(np.ascontiguousarray(np.asarray(x, float).reshape(1, -1)), dt,
                             ctx, out)
        return out[0]

    def function_points(self, X: np.ndarray, dt: float, ctx: Context,
                        out: np.ndarray) -> None:
        """:meth:`function` of every row of ``X`` (npts, n) into ``out``."""
        raise NotImplementedError

    def jacobian(self, x: np.ndarray, dt: float, ctx: Context) -> np.ndarray:
        """∂function/∂x, (n, n)."""
        raise NotImplementedError

    def covariance(self, dt: float) -> np.ndarray:
        """Process noise covariance Q over ``dt`` s, (n, n)."""
        raise NotImplementedError

    def transition_stacked(self, dt: np.ndarray) -> np.ndarray:
        """F (n, d, d) of a linear model for the time steps ``dt`` (n,) s of stacked tracks
        held in world coordinates (no observer terms)."""
        raise NotImplementedError(f"{self.name}: no stacked (many-track) form")

    def covariance_stacked(self, dt: np.ndarray) -> np.ndarray:
        """Q (n, d, d) for the time steps ``dt`` (n,) s of stacked tracks."""
        raise NotImplementedError(f"{self.name}: no stacked (many-track) form")


class MeasurementModel(Component):
    """Measurement model z = h(X; ctx) + w, w ~ N(0, R)."""

    name = "measurement"
    angular: ClassVar[tuple[bool, ...]] = ()
    #: period of the angular components (2π for radians, 360 for a model in degrees)
    angle_period: ClassVar[float] = 2.0 * math.pi
    #: number of leading state components h reads (None: all); sample-point filters form
    #: only those rows of their points (Stone Soup's measurement ``mapping``)
    state_rows: ClassVar[int | None] = None

    @property
    def ndim_meas(self) -> int:
        return len(self.angular)

    @property
    def angular_mask(self) -> np.ndarray:
        return np.array(self.angular, dtype=np.bool_)

    def function(self, x: np.ndarray, ctx: Context) -> np.ndarray:
        """Predicted measurement h(x) (m,)."""
        out = np.empty((1, self.ndim_meas))
        self.function_points(np.ascontiguousarray(np.asarray(x, float).reshape(1, -1)), ctx,
                             out)
        return out[0]

    def function_points(self, X: np.ndarray, ctx: Context, out: np.ndarray) -> None:
        """h of every row of ``X`` (npts, n) into ``out`` (npts, m)."""
        raise NotImplementedError

    def jacobian(self, x: np.ndarray, ctx: Context) -> np.ndarray:
        """∂h/∂x, (m, n)."""
        raise NotImplementedError

    def covariance(self, ctx: Context | None = None) -> np.ndarray:
        """Measurement noise covariance R (m, m)."""
        raise NotImplementedError

    def residual(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """a − b with the angular components wrapped to [−π, π)."""
        d = np.asarray(a, float) - np.asarray(b, float)
        return np.where(self.angular_mask, wrap_pi(d), d)

    def loglik_particles(self, rel: np.ndarray, z: np.ndarray, ctx: Context,
                         out: np.ndarray) -> None:
        """Log-likelihood of ``z`` for every row of ``rel`` (N, n), up to the constant
        :meth:`loglik_norm` (the particle filter's weights). Generic Gaussian form; models
        override it with a kernel."""
        Z = np.empty((rel.shape[0], self.ndim_meas))
        self.function_points(np.ascontiguousarray(rel), ctx, Z)
        d = self.residual(np.asarray(z, float)[None, :], Z)
        L = np.linalg.cholesky(self.covariance(ctx))
        e = np.linalg.solve(L, d.T)
        out[:] = -0.5 * np.sum(e * e, axis=0)

    def loglik_norm(self, ctx: Context | None = None) -> float:
        """log((2π)^{m/2} |R|^{1/2}), the constant left out by :meth:`loglik_particles`."""
        R = self.covariance(ctx)
        return 0.5 * self.ndim_meas * math.log(2.0 * math.pi) + 0.5 * math.log(
            np.linalg.det(R))

    # ------------------------------------------------------------- stacked (many tracks)
    def function_stacked(self, X: np.ndarray, ctx: Context | None) -> np.ndarray:
        """h of stacked states X (n, d) → (n, m) (default: :meth:`function_points`)."""
        out = np.empty((X.shape[0], self.ndim_meas))
        self.function_points(np.ascontiguousarray(X, dtype=float), ctx, out)
        return out

    def jacobian_stacked(self, X: np.ndarray, ctx: Context | None) -> np.ndarray:
        """∂h/∂x of stacked states, (n, m, d) (default: :meth:`jacobian` row by row)."""
        if X.shape[0] == 0:
            return np.zeros((0, self.ndim_meas, X.shape[1]))
        return np.stack([self.jacobian(x, ctx) for x in X])

    def noise_stacked(self, Z: np.ndarray, ctx: Context | None) -> np.ndarray:
        """R of the measurements Z (m, k) of a scan: (k, k) shared or (m, k, k) each
        (default: :meth:`covariance`)."""
        return np.asarray(self.covariance(ctx), float)

    def wrap_stacked(self, v: np.ndarray) -> np.ndarray:
        """Residuals ``v`` (..., m) with the angular components wrapped to
        [−period/2, period/2)."""
        idx = [i for i, a in enumerate(self.angular) if a]
        if idx:
            v = v.copy()
            p = self.angle_period
            v[..., idx] = (v[..., idx] + p / 2) % p - p / 2
        return v

    def as_bearing(self, z: np.ndarray, ctx: Context) -> float | None:
        """The true bearing (rad) equivalent to ``z`` for bearings-only updates (the shifted
        Rayleigh filter), or None when the model is not a bearing."""
        return None

    @property
    def bearing_sigma(self) -> float | None:
        """σ of the bearing (rad) for :meth:`as_bearing`, or None."""
        return None
