"""A measurement model of the observer-relative state applied to tracks held in world
coordinates.

The package's measurement models read the relative state X = X^t − X^o of the L-R paper
eq. (1) (the single-target trackers hold that state). The multi-target manager holds its
tracks in world coordinates, the observer state ``ctx.own`` [x, y, ẋ, ẏ] being the scan's
context; :class:`ObserverRelative` subtracts it from the first four components before calling
the model, which is all the change of frame takes (the Jacobian of a translation is I), the
same as Stone Soup's sensor ``translation_offset`` / ``velocity``.
"""

from __future__ import annotations

import numpy as np

from arrayproc.track.models.base import MeasurementModel
from arrayproc.track.state import Context

__all__ = ["ObserverRelative"]


class ObserverRelative(MeasurementModel):
    """``model`` on world-frame states: h_w(X; ctx) = h(X − [o, 0…]; ctx), o = ``ctx.own``."""

    name = "observer_relative"

    def __init__(self, model: MeasurementModel) -> None:
        self.model = model
        self.angular = model.angular
        self.angle_period = model.angle_period
        self.state_rows = model.state_rows

    def __repr__(self) -> str:
        return f"ObserverRelative({self.model!r})"

    @staticmethod
    def relative(X: np.ndarray, ctx: Context) -> np.ndarray:
        """Stacked world states X (n, d) made relative to the observer ``ctx.own``."""
        X = np.array(X, dtype=float, ndmin=2)
        X[:, :4] -= np.asarray(ctx.own, float)[None, :4]
        return X

    def function_points(self, X, ctx, out) -> None:
        self.model.function_points(self.relative(X, ctx), ctx, out)

    def jacobian(self, x: np.ndarray, ctx: Context) -> np.ndarray:
        return self.model.jacobian(self.relative(x, ctx)[0], ctx)

    def covariance(self, ctx: Context | None = None) -> np.ndarray:
        return self.model.covariance(ctx)

    def function_stacked(self, X: np.ndarray, ctx: Context) -> np.ndarray:
        return self.model.function_stacked(self.relative(X, ctx), ctx)

    def jacobian_stacked(self, X: np.ndarray, ctx: Context) -> np.ndarray:
        return self.model.jacobian_stacked(self.relative(X, ctx), ctx)

    def noise_stacked(self, Z: np.ndarray, ctx: Context | None) -> np.ndarray:
        return self.model.noise_stacked(Z, ctx)
