"""Gaussian bearings-only filters behind one predict/update interface (L-R paper section IV).

``EKF``, ``UKF``, ``CKF``, ``GHF`` (Gauss-Hermite, order configurable) and ``SRF`` (shifted
Rayleigh, Clark, Vinter & Yaqoob 2007) all hold a relative state ``x`` and covariance ``P``
(SI units, radians; see :mod:`arrayproc.track.models`) and expose

- ``initialize(x0, P0)``
- ``predict(T, own_prev, own_next)`` — time update over ``T`` s with the observer states
  ``[x, y, ẋ, ẏ]`` (m, m/s) at the start and end of the step (L-R paper eqs. (1)-(6));
- ``update(bearing_deg) -> float`` — bearing update (eq. (7)), returns the log-likelihood of the
  measurement used by the L-R weights (eq. (9), or section IV's likelihood for the SRF).

The numerical work is done by the numba kernels of :mod:`arrayproc.track._kernels`, which
the Monte Carlo engine also calls, so the class and the vectorised runs are the same code.
Covariances are symmetrised after every step; a non-positive-definite covariance is repaired
with a diagonal jitter and counted in ``n_repairs``; a non-finite state raises
:class:`FilterDivergence` — never a silent NaN.

``FILTERS`` maps a configuration name to its class; other trackers (e.g. a particle filter)
register themselves there.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from arrayproc.errors import ConfigError
from arrayproc.track import _kernels as kc
from arrayproc.track.models import MotionModel
from arrayproc.track.points import cubature_points, gauss_hermite_points, unscented_points


class FilterDivergence(ArithmeticError):
    """A filter's state or covariance became non-finite (the track is lost)."""


class GaussianFilter:
    """Common state handling; subclasses set ``kind`` and their sample points."""

    name = "gaussian"
    kind = kc.KIND_SP

    def __init__(self, model: MotionModel, sigma_deg: float = 1.5) -> None:
        if not sigma_deg > 0:
            raise ConfigError("tracker: sigma_bearing_deg must be > 0")
        self.model = model
        self.sigma = math.radians(float(sigma_deg))
        n = model.dim
        self.x = np.zeros(n)
        self.P = np.eye(n)
        self.n_repairs = 0
        # points for the measurement update (U) and for the time update (Upred)
        self.U, self.wm, self.wc = cubature_points(n)
        self.Upred, self.wmpred, self.wcpred = self.U, self.wm, self.wc

    def initialize(self, x0: np.ndarray, P0: np.ndarray) -> None:
        self.x = np.array(x0, dtype=float).reshape(self.model.dim)
        self.P = np.array(P0, dtype=float).reshape(self.model.dim, self.model.dim)

    def _check(self, status: int, what: str) -> None:
        if status < 0:
            raise FilterDivergence(f"{self.name}: non-finite state after {what}")
        self.n_repairs += status

    def predict(self, T: float, own_prev: np.ndarray, own_next: np.ndarray) -> None:
        """Time update, L-R paper eqs. (1)-(6)."""
        st = kc.filter_predict(self.kind, self.model.code, self.x, self.P, float(T),
                               np.asarray(own_prev, float), np.asarray(own_next, float),
                               self.model.q1, self.model.q2, self.Upred, self.wmpred,
                               self.wcpred)
        self._check(st, "predict")

    def update(self, bearing_deg: float) -> float:
        """Bearing update (eq. (7)); returns the measurement log-likelihood (eq. (9))."""
        ll, st = kc.filter_update(self.kind, self.x, self.P, math.radians(float(bearing_deg)),
                                  self.sigma, self.U, self.wm, self.wc)
        self._check(st, "update")
        return float(ll)

    def kernel_args(self) -> tuple:
        """(kind, U, wm, wc, Upred, wmpred, wcpred) for :func:`track_core.run_track`."""
        return (self.kind, self.U, self.wm, self.wc, self.Upred, self.wmpred, self.wcpred)


class EKF(GaussianFilter):
    """Extended Kalman filter: first-order linearisation, Joseph-form update."""

    name = "ekf"
    kind = kc.KIND_EKF


class UKF(GaussianFilter):
    """Unscented Kalman filter with scaled points (α, β, κ; default κ = 3 − n)."""

    name = "ukf"

    def __init__(self, model: MotionModel, sigma_deg: float = 1.5, alpha: float = 1.0,
                 beta: float = 0.0, kappa: float | None = None) -> None:
        super().__init__(model, sigma_deg)
        self.U, self.wm, self.wc = unscented_points(model.dim, alpha, beta, kappa)
        self.Upred, self.wmpred, self.wcpred = self.U, self.wm, self.wc


class CKF(GaussianFilter):
    """Cubature Kalman filter (2n third-degree spherical-radial points)."""

    name = "ckf"


class GHF(GaussianFilter):
    """Gauss-Hermite filter with ``gh_order`` points per axis (order**n points)."""

    name = "ghf"

    def __init__(self, model: MotionModel, sigma_deg: float = 1.5, gh_order: int = 3) -> None:
        super().__init__(model, sigma_deg)
        self.U, self.wm, self.wc = gauss_hermite_points(model.dim, gh_order)
        self.Upred, self.wmpred, self.wcpred = self.U, self.wm, self.wc


class SRF(GaussianFilter):
    """Shifted Rayleigh filter: exact moment-matched bearing update; exact linear prediction for
    CV; cubature points for the CT prediction (L-R paper section IV). ``likelihood`` for the
    L-R weights: ``"paper"`` (section IV's N(γb; Hx̂, V)) or ``"exact"`` (the bearing's own
    projected-normal density)."""

    name = "srf"
    kind = kc.KIND_SRF

    def __init__(self, model: MotionModel, sigma_deg: float = 1.5,
                 likelihood: str = "exact") -> None:
        super().__init__(model, sigma_deg)
        if likelihood not in ("paper", "exact"):
            raise ConfigError("tracker: srf likelihood must be 'paper' or 'exact'")
        self.likelihood = likelihood
        self.kind = kc.KIND_SRF if likelihood == "paper" else kc.KIND_SRF_EXACT


FILTERS: dict[str, type[GaussianFilter]] = {
    "ekf": EKF, "ukf": UKF, "ckf": CKF, "ghf": GHF, "srf": SRF,
}


def make_filter(name: str, model: MotionModel, sigma_deg: float = 1.5,
                **params: Any) -> GaussianFilter:
    """Build a filter from its configuration name and parameters (ConfigError on bad ones)."""
    try:
        cls = FILTERS[name]
    except KeyError:
        raise ConfigError(f"tracker: unknown filter {name!r} (one of {', '.join(FILTERS)})"
                          ) from None
    try:
        return cls(model, sigma_deg, **params)
    except TypeError as e:
        raise ConfigError(f"tracker: bad parameter for filter {name!r}: {e}") from None


# Issue 7: the regularized particle filter (bearings only) through the same step interface.
from arrayproc.track.pf import RPFTracker  # noqa: E402

FILTERS["rpf"] = RPFTracker  # type: ignore[assignment]
