"""Time differences of arrival at the array's elements, thesis (Colin 2011) eqs. (3.37)-(3.40).

The measurement is the vector of delays of the non-reference elements relative to a reference
element, τ_n = (|s − p_n| − |s − p_ref|)/c (eqs. (3.38)-(3.39)), for a source at
s = [x, y, dz] relative to the observer's reference point (the relative state's position and a
fixed vertical offset ``source_dz_m``, z down). ``elements`` are the element positions (n, 3) in
the same world-aligned frame, relative to the reference point, m. The noise covariance is that
of delays measured against one reference channel (:func:`arrayproc.geo.tdoa.reference_covariance`)
with per-delay σ ``sigma_s``. The state dynamics, eq. (3.40), are any motion model. The geometry
(delays, Jacobian) is :mod:`arrayproc.geo.tdoa`.

This file is the whole cost of a new measurement type: the filters and the L-R scheme use it
through the :class:`~arrayproc.track.models.base.MeasurementModel` interface.
"""

from __future__ import annotations

import numpy as np

from arrayproc.errors import ConfigError
from arrayproc.geo import tdoa as geo_tdoa
from arrayproc.track.base import Param
from arrayproc.track.models.base import MeasurementModel
from arrayproc.track.state import Context

__all__ = ["TDOA", "RowTDOA"]


class TDOA(MeasurementModel):
    """TDOA of every element but ``reference`` (s), thesis eqs. (3.37)-(3.39)."""

    name = "tdoa"
    state_rows = 2
    params = {
        "elements": Param("any", doc="element positions (n, 3), m, relative to the observer"),
        "reference": Param("int", 0, "reference element"),
        "sound_speed": Param("float", 1500.0, "c, m/s",
                             check=lambda v: None if v > 0 else "must be > 0"),
        "sigma_s": Param("float", 1e-5, "delay noise σ, s",
                         check=lambda v: None if v > 0 else "must be > 0"),
        "source_dz_m": Param("float", 0.0, "source depth below the reference point, m"),
    }

    def _setup(self) -> None:
        p = np.asarray(self.elements, dtype=float)
        if p.ndim != 2 or p.shape[1] != 3 or p.shape[0] < 2:
            raise ConfigError(f"{self.name}.elements: expected an (n, 3) array, n >= 2")
        if not 0 <= self.reference < p.shape[0]:
            raise ConfigError(f"{self.name}.reference: must index an element")
        self.elements = p
        self._keep = np.flatnonzero(np.arange(p.shape[0]) != self.reference)
        self.angular = (False,) * self._keep.size
        self._R = geo_tdoa.reference_covariance(np.full(self._keep.size, self.sigma_s))

    def _source(self, X: np.ndarray) -> np.ndarray:
        X = np.asarray(X, float)
        return np.stack([X[..., 0], X[..., 1], np.full(X.shape[:-1], self.source_dz_m)], -1)

    def function_points(self, X, ctx, out) -> None:
        tau = geo_tdoa.predicted_delays(self._source(X), self.elements, self.reference,
                                        self.sound_speed)
        out[:] = tau[..., self._keep]

    def jacobian(self, x: np.ndarray, ctx: Context | None = None) -> np.ndarray:
        J = geo_tdoa.jacobian(self._source(x), self.elements, self.reference, self.sound_speed)
        H = np.zeros((self._keep.size, np.size(x)))
        H[:, :2] = J[self._keep, :2]
        return H

    def covariance(self, ctx: Context | None = None) -> np.ndarray:
        return self._R


class RowTDOA(TDOA):
    """:class:`~arrayproc.track.models.tdoa.TDOA` with a σ per delay (``sigma_row``, the
    non-reference delays in element order), the noise covariance of delays measured against
    one reference channel (:func:`arrayproc.geo.tdoa.reference_covariance`)."""

    name = "tdoa_row"
    params = {"sigma_row": Param("any", None, "σ of each non-reference delay, s")}

    def _setup(self) -> None:
        super()._setup()
        if self.sigma_row is not None:
            s = np.asarray(self.sigma_row, float).reshape(-1)
            if s.size != self._keep.size or not np.all(np.isfinite(s) & (s > 0)):
                raise ConfigError(f"{self.name}.sigma_row: need {self._keep.size} positive "
                                  "finite values")
            self._R = geo_tdoa.reference_covariance(s)
