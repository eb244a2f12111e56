"""The extended Kalman filter on many stacked tracks at once: X (n, d), P (n, d, d).

The multi-target manager predicts every live track of a scan, forms the innovation of every
(track, measurement) pair and updates the assigned pairs, each as one batched NumPy operation
(Bar-Shalom, Li & Kirubarajan 2001, eqs. 5.2.3-5 to 5.2.3-15 and sec. 10.3; Joseph-form
covariance update). The motion and measurement models are the package's
(:mod:`arrayproc.track.models`), through their stacked methods (``transition_stacked``,
``covariance_stacked``, ``function_stacked``, ``jacobian_stacked``, ``noise_stacked``,
``wrap_stacked``); for a linear measurement (a selection z = H x) the EKF is the Kalman filter
exactly. Stacked tracks are held in world coordinates: a model that reads the observer-relative
state is wrapped in :class:`~arrayproc.track.models.frame.ObserverRelative`.

Written here (rather than taken from a library) because the manager needs the whole set of
tracks in one array operation; Stone Soup and FilterPy step one track at a time.
"""

from __future__ import annotations

import math
from typing import Any, Protocol

import numpy as np

from arrayproc.track.models.base import MeasurementModel, MotionModel

__all__ = ["StackedFilter", "StackedEKF", "predict_stacked", "innovation_stacked",
           "update_stacked", "gain_update"]


class StackedFilter(Protocol):
    """What :class:`~arrayproc.track.manage.manager.TrackManager` needs of a filter."""

    def predict(self, X: np.ndarray, P: np.ndarray, dt: np.ndarray, ctx: Any
                ) -> tuple[np.ndarray, np.ndarray]: ...

    def innovation(self, X: np.ndarray, P: np.ndarray, Z: np.ndarray, ctx: Any
                   ) -> tuple[np.ndarray, np.ndarray]: ...

    def update(self, X: np.ndarray, P: np.ndarray, Z: np.ndarray, ctx: Any, idx: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...


def predict_stacked(motion: MotionModel, X: np.ndarray, P: np.ndarray, dt: np.ndarray,
                    q_scale: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Time update of stacked tracks with a linear motion model (BLK eqs. 5.2.3-5, 5.2.3-7):
    X ← F X, P ← F P Fᵀ + s Q, s the step's process-noise multiplier."""
    F = motion.transition_stacked(dt)
    Q = motion.covariance_stacked(dt)
    Xp = np.einsum("nij,nj->ni", F, X)
    Pp = F @ P @ F.transpose(0, 2, 1) + (Q if q_scale == 1.0 else float(q_scale) * Q)
    return Xp, 0.5 * (Pp + Pp.transpose(0, 2, 1))


def gain_update(X: np.ndarray, P: np.ndarray, nu: np.ndarray, H: np.ndarray, R: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Kalman update of stacked pairs: X (a, d), P (a, d, d), innovations nu (a, k), measurement
    Jacobians H (a, k, d), noise R (a, k, k). Joseph form (BLK eq. 5.2.3-18); returns X, P and
    ln N(ν; 0, S) (a,)."""
    PHt = P @ H.transpose(0, 2, 1)
    S = H @ PHt + R
    S = 0.5 * (S + S.transpose(0, 2, 1))
    L = np.linalg.cholesky(S)
    K = np.linalg.solve(S, PHt.transpose(0, 2, 1)).transpose(0, 2, 1)
    Xn = X + np.einsum("aik,ak->ai", K, nu)
    ImKH = np.eye(X.shape[1])[None] - K @ H
    Pn = ImKH @ P @ ImKH.transpose(0, 2, 1) + K @ R @ K.transpose(0, 2, 1)
    w = np.linalg.solve(L, nu[..., None])[..., 0]
    k = nu.shape[1]
    ll = -0.5 * (np.einsum("ai,ai->a", w, w) + k * math.log(2 * math.pi)) \
        - np.log(np.abs(np.diagonal(L, axis1=-2, axis2=-1))).sum(-1)
    return Xn, 0.5 * (Pn + Pn.transpose(0, 2, 1)), ll


def innovation_stacked(model: MeasurementModel, X: np.ndarray, P: np.ndarray, Z: np.ndarray,
                       ctx: Any) -> tuple[np.ndarray, np.ndarray]:
    """ν (n, m, k) of every (track, measurement) pair, wrapped on angles, and
    S = H P Hᵀ + R (n, k, k) or (n, m, k, k) (BLK eq. 5.2.3-9)."""
    Z = np.asarray(Z, float).reshape(-1, model.ndim_meas)
    zh = model.function_stacked(X, ctx)
    H = model.jacobian_stacked(X, ctx)
    nu = model.wrap_stacked(Z[None, :, :] - zh[:, None, :])
    R = model.noise_stacked(Z, ctx)
    HPH = H @ P @ H.transpose(0, 2, 1)
    return nu, (HPH + R if R.ndim == 2 else HPH[:, None] + R)


def update_stacked(model: MeasurementModel, X: np.ndarray, P: np.ndarray, Z: np.ndarray,
                   ctx: Any, idx: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Update of tracks X (a, d), P (a, d, d) with the measurements ``Z[idx]`` of the scan
    Z (m, k), linearised at the predicted states (BLK eqs. 5.2.3-11 to 5.2.3-15, sec. 10.3).
    Returns X, P and the log-likelihoods ln N(ν; 0, S) (a,)."""
    k = model.ndim_meas
    Z = np.asarray(Z, float).reshape(-1, k)
    idx = np.asarray(idx, np.int64)
    nu = model.wrap_stacked(Z[idx] - model.function_stacked(X, ctx))
    R = model.noise_stacked(Z, ctx)
    R = np.broadcast_to(R, (idx.size, k, k)) if R.ndim == 2 else R[idx]
    return gain_update(X, P, nu, model.jacobian_stacked(X, ctx), R)


class StackedEKF:
    """The EKF of stacked tracks (:meth:`arrayproc.track.filters.EKF.predict_stacked` …)
    composed with a motion and a measurement model: the
    ``predict`` / ``innovation`` / ``update`` a :class:`~arrayproc.track.manage.manager.
    TrackManager` calls. ``ctx`` of each call is the scan's
    :class:`~arrayproc.track.state.Context` (or None), read by the models; its ``q_scale``
    multiplies Q."""

    def __init__(self, motion_model: MotionModel, measurement_model: MeasurementModel) -> None:
        self.motion_model = motion_model
        self.measurement_model = measurement_model

    def predict(self, X: np.ndarray, P: np.ndarray, dt: np.ndarray, ctx: Any = None
                ) -> tuple[np.ndarray, np.ndarray]:
        """Time update of all tracks."""
        return predict_stacked(self.motion_model, X, P, dt,
                               getattr(ctx, "q_scale", 1.0))

    def innovation(self, X: np.ndarray, P: np.ndarray, Z: np.ndarray, ctx: Any = None
                   ) -> tuple[np.ndarray, np.ndarray]:
        """ν (n, m, k) and S of every (track, measurement) pair."""
        return innovation_stacked(self.measurement_model, X, P, Z, ctx)

    def update(self, X: np.ndarray, P: np.ndarray, Z: np.ndarray, ctx: Any, idx: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Measurement update of the pairs (tracks, ``Z[idx]``)."""
        return update_stacked(self.measurement_model, X, P, Z, ctx, idx)
