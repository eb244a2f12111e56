"""Gaussian filters behind one predict/update interface (L-R paper section IV), for any motion
and measurement model.

``EKF``, ``UKF``, ``CKF``, ``GHF`` (Gauss-Hermite, order configurable) and ``SRF`` (shifted
Rayleigh, Clark, Vinter & Yaqoob 2007) expose

- ``initialize(x0, P0, t=0) -> GaussianState``;
- ``predict(state, motion_model, dt, ctx) -> GaussianState`` — time update over ``dt`` s with
  the observer context (L-R paper eqs. (1)-(6));
- ``update(state, z, measurement_model, ctx) -> (GaussianState, log-likelihood)`` — any
  :class:`~arrayproc.track.models.base.MeasurementModel`; the log-likelihood is what the L-R
  weights use (eq. (9), or section IV's likelihood for the SRF);
- ``innovation(state, z, measurement_model, ctx) -> (ν, S)`` for gating.

The SRF's update is bearings-only by construction: it takes measurement models whose
``as_bearing`` gives a bearing (bearing, mirrored bearing) and raises ConfigError for others.
The numerical work is in :mod:`arrayproc.track.filters._kernels`. Covariances are symmetrised
after every step; a non-positive-definite covariance is repaired with a diagonal jitter and
counted in ``n_repairs``; a non-finite state raises :class:`FilterDivergence` — never a silent
NaN. Filters hold no track state; they can serve any number of tracks.
"""

from __future__ import annotations

import numpy as np

from arrayproc.errors import ConfigError
from arrayproc.track.base import Param
from arrayproc.track.filters import _kernels as kf
from arrayproc.track.filters import stacked
from arrayproc.track.filters.base import Filter, FilterDivergence
from arrayproc.track.filters.points import (
    cubature_points,
    gauss_hermite_points,
    unscented_points,
)
from arrayproc.track.models.base import MeasurementModel, MotionModel
from arrayproc.track.state import Context, GaussianState

__all__ = ["GaussianFilter", "EKF", "UKF", "CKF", "GHF", "SRF", "FilterDivergence"]


class GaussianFilter(Filter):
    """Common state handling; subclasses choose their unit sample points (``_points``)."""

    name = "gaussian"
    linearised = False  # EKF: Jacobians instead of sample points

    def _setup(self) -> None:
        self.n_repairs = 0
        self._pts: dict[int, tuple] = {}

    def _points(self, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(U, wm, wc) unit points of the update for state dimension n."""
        return cubature_points(n)

    def _pred_points(self, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(U, wm, wc) unit points of the time update."""
        return self.points(n)

    def points(self, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The filter's unit sample points and weights for state dimension ``n`` (cached)."""
        if n not in self._pts:
            self._pts[n] = self._points(n)
        return self._pts[n]

    def kernel_points(self, n: int) -> tuple:
        """(U, wm, wc, Upred, wmpred, wcpred) for the fused L-R Monte Carlo kernel."""
        return (*self.points(n), *self._pred_points(n))

    def initialize(self, x0: np.ndarray, P0: np.ndarray, t: float = 0.0) -> GaussianState:
        """The state N(x0, P0) at time ``t``."""
        return GaussianState(x0, P0, t)

    def _check(self, status: int, what: str) -> None:
        if status < 0:
            raise FilterDivergence(f"{self.name}: non-finite state after {what}")
        self.n_repairs += status

    # -------------------------------------------------------------------------- predict
    def _linear_predict(self, state, motion_model, dt, ctx) -> GaussianState:
        x = state.x.copy()
        P = state.P.copy()
        st = kf.ekf_predict(x, P, motion_model.jacobian(x, dt, ctx),
                            motion_model.function(x, dt, ctx), motion_model.covariance(dt))
        self._check(st, "predict")
        return GaussianState(x, P, state.t + dt)

    def _sp_predict(self, state, motion_model, dt, ctx) -> GaussianState:
        x = state.x.copy()
        P = state.P.copy()
        U, wm, wc = self._pred_points(x.size)
        Xs = np.empty((U.shape[0], x.size))
        st = kf.sp_predict_points(x, P, U, Xs)
        self._check(st, "predict")
        Y = np.empty_like(Xs)
        motion_model.function_points(Xs, float(dt), ctx, Y)
        st = kf.sp_predict_moments(x, P, Y, motion_model.covariance(dt), wm, wc, st)
        self._check(st, "predict")
        return GaussianState(x, P, state.t + dt)

    def predict(self, state: GaussianState, motion_model: MotionModel, dt: float,
                ctx: Context) -> GaussianState:
        """Time update over ``dt`` s (L-R paper eqs. (1)-(6)).

        Parameters
        ----------
        state : GaussianState
            State at the previous time.
        motion_model : MotionModel
            E.g. :class:`~arrayproc.track.models.ConstantVelocity`.
        dt : float
            Time step, s.
        ctx : Context
            Observer states at the previous (``own_prev``) and the new (``own``) time.

        Returns
        -------
        GaussianState
            The predicted state (a new object).
        """
        if self.linearised:
            return self._linear_predict(state, motion_model, dt, ctx)
        return self._sp_predict(state, motion_model, dt, ctx)

    # --------------------------------------------------------------------------- update
    def update(self, state: GaussianState, z: np.ndarray | float,
               measurement_model: MeasurementModel, ctx: Context
               ) -> tuple[GaussianState, float]:
        """Measurement update with any measurement model.

        Parameters
        ----------
        state : GaussianState
            Predicted state.
        z : array_like
            Measurement (m,), in the model's units (rad for angles).
        measurement_model : MeasurementModel
        ctx : Context
            Observer context at the measurement time.

        Returns
        -------
        GaussianState
            Updated state (a new object).
        float
            Log-likelihood of ``z`` (L-R paper eq. (9)).
        """
        x = state.x.copy()
        P = state.P.copy()
        zz = np.ascontiguousarray(np.asarray(z, dtype=float).reshape(-1))
        R = np.ascontiguousarray(measurement_model.covariance(ctx))
        ang = measurement_model.angular_mask
        if self.linearised:
            ll, st = kf.ekf_update(x, P, zz, measurement_model.function(x, ctx),
                                   np.ascontiguousarray(measurement_model.jacobian(x, ctx)),
                                   R, ang)
        else:
            U, wm, wc = self.points(x.size)
            Xs = np.zeros((U.shape[0], x.size))
            L = np.empty((x.size, x.size))
            st = kf.sp_update_points(x, P, U, Xs, L, _rows(measurement_model, x.size))
            self._check(st, "update")
            Zs = np.empty((U.shape[0], zz.size))
            measurement_model.function_points(Xs, ctx, Zs)
            ll, st = kf.sp_update_correct(x, P, L, zz, Zs, R, ang, U, wm, wc, st)
        self._check(st, "update")
        return GaussianState(x, P, state.t), float(ll)

    def innovation(self, state: GaussianState, z: np.ndarray | float,
                   measurement_model: MeasurementModel, ctx: Context
                   ) -> tuple[np.ndarray, np.ndarray]:
        """Innovation ν = z − ẑ (angles wrapped) and its covariance S, for gating.

        Parameters
        ----------
        state : GaussianState
            Predicted state.
        z : array_like
            Measurement (m,).
        measurement_model : MeasurementModel
        ctx : Context

        Returns
        -------
        nu : (m,) ndarray
        S : (m, m) ndarray
        """
        zz = np.ascontiguousarray(np.asarray(z, dtype=float).reshape(-1))
        R = np.ascontiguousarray(measurement_model.covariance(ctx))
        ang = measurement_model.angular_mask
        x = state.x
        if self.linearised:
            return kf.gaussian_innovation(
                np.ascontiguousarray(state.P), measurement_model.function(x, ctx), zz,
                np.ascontiguousarray(measurement_model.jacobian(x, ctx)), R, ang)
        U, wm, wc = self.points(x.size)
        P = state.P.copy()
        Xs = np.zeros((U.shape[0], x.size))
        L = np.empty((x.size, x.size))
        self._check(kf.sp_update_points(x.copy(), P, U, Xs, L, _rows(measurement_model, x.size)),
                    "innovation")
        Zs = np.empty((U.shape[0], zz.size))
        measurement_model.function_points(Xs, ctx, Zs)
        zp, S, _ = kf.sp_measurement_moments(Zs, R, ang, U, wm, wc)
        nu = np.empty(zz.size)
        kf.residual(zz, zp, ang, nu)
        return nu, S


def _rows(measurement_model: MeasurementModel, n: int) -> int:
    """State rows the model reads (all if it does not say)."""
    r = measurement_model.state_rows
    return n if r is None else min(int(r), n)


class EKF(GaussianFilter):
    """Extended Kalman filter: first-order linearisation, Joseph-form update.

    One track through :meth:`predict` / :meth:`update` (numba kernels), or many stacked tracks
    X (n, d), P (n, d, d) through :meth:`predict_stacked` / :meth:`innovation_stacked` /
    :meth:`update_stacked` (the batched form of :mod:`arrayproc.track.filters.stacked`)."""

    name = "ekf"
    linearised = True

    def predict_stacked(self, X: np.ndarray, P: np.ndarray, motion_model: MotionModel,
                        dt: np.ndarray, q_scale: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
        """Time update of stacked tracks (:func:`~arrayproc.track.filters.stacked.
        predict_stacked`)."""
        return stacked.predict_stacked(motion_model, X, P, dt, q_scale)

    def innovation_stacked(self, X: np.ndarray, P: np.ndarray, Z: np.ndarray,
                           measurement_model: MeasurementModel, ctx: Context | None
                           ) -> tuple[np.ndarray, np.ndarray]:
        """ν and S of every (track, measurement) pair."""
        return stacked.innovation_stacked(measurement_model, X, P, Z, ctx)

    def update_stacked(self, X: np.ndarray, P: np.ndarray, Z: np.ndarray, idx: np.ndarray,
                       measurement_model: MeasurementModel, ctx: Context | None
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Update of the pairs (tracks, ``Z[idx]``): X, P and the log-likelihoods."""
        return stacked.update_stacked(measurement_model, X, P, Z, ctx, idx)


class UKF(GaussianFilter):
    """Unscented Kalman filter with scaled points (α, β, κ; default κ = 3 − n)."""

    name = "ukf"
    params = {"alpha": Param("float", 1.0, "spread α"),
              "beta": Param("float", 0.0, "prior-knowledge β (2 for Gaussian)"),
              "kappa": Param("float", None, "secondary scaling κ (default 3 − n)")}

    def _points(self, n: int):
        return unscented_points(n, self.alpha, self.beta, self.kappa)


class CKF(GaussianFilter):
    """Cubature Kalman filter (2n third-degree spherical-radial points)."""

    name = "ckf"


class GHF(GaussianFilter):
    """Gauss-Hermite filter with ``gh_order`` points per axis (order**n points)."""

    name = "ghf"
    params = {"gh_order": Param("int", 3, "points per axis",
                                check=lambda v: None if 2 <= v <= 10 else
                                "must be between 2 and 10")}

    def _points(self, n: int):
        return gauss_hermite_points(n, self.gh_order)


class SRF(GaussianFilter):
    """Shifted Rayleigh filter: exact moment-matched bearing update; exact linear prediction for
    linear motion models (CV), cubature points otherwise (CT) (L-R paper section IV).
    ``likelihood`` for the L-R weights: ``"paper"`` (section IV's N(γb; Hx̂, V)) or ``"exact"``
    (the bearing's own projected-normal density)."""

    name = "srf"
    params = {"likelihood": Param("str", "exact", "L-R likelihood",
                                  choices=("paper", "exact"))}

    def _pred_points(self, n: int):
        return cubature_points(n)

    def kernel_points(self, n: int) -> tuple:
        return (*cubature_points(n), *cubature_points(n))

    def predict(self, state, motion_model, dt, ctx) -> GaussianState:
        if motion_model.linear:
            return self._linear_predict(state, motion_model, dt, ctx)
        return self._sp_predict(state, motion_model, dt, ctx)

    def update(self, state, z, measurement_model, ctx) -> tuple[GaussianState, float]:
        zb = measurement_model.as_bearing(z, ctx)
        if zb is None:
            raise ConfigError(f"srf: the shifted Rayleigh update needs a bearing measurement, "
                              f"not {measurement_model.name!r}")
        x = state.x.copy()
        P = state.P.copy()
        ll, st = kf.srf_update(x, P, float(zb), float(measurement_model.bearing_sigma),
                               self.likelihood == "exact")
        self._check(st, "update")
        return GaussianState(x, P, state.t), float(ll)

    def innovation(self, state, z, measurement_model, ctx):
        """Linearised bearing innovation (the SRF's update is not linear-Gaussian)."""
        return EKF().innovation(state, z, measurement_model, ctx)


