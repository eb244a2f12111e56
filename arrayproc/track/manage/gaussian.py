"""Vectorised Gaussian filter steps for the track manager: every live track at once.

The manager calls ``predict`` on all live tracks of a scan, ``innovation`` on every
(track, measurement) pair and ``update`` on the assigned pairs, each as one batched NumPy
operation over stacked states (n, d) and covariances (n, d, d). Two filters share that
interface:

- :class:`KalmanBatch` — Kalman filter for a linear measurement z = H x + w (Kalman 1960;
  Bar-Shalom, Li & Kirubarajan 2001, eqs. 5.2.3-5 to 5.2.3-15), Joseph-form covariance update;
- :class:`EKFBatch` — extended Kalman filter for a nonlinear model (BLK 2001 sec. 10.3) with
  innovations wrapped on angular components.

Motion: the nearly-constant-velocity model with white-noise acceleration of spectral density q
(BLK 2001 eq. 6.2.2-12): F = [[I, T I], [0, I]], Q = q [[T³/3 I, T²/2 I], [T²/2 I, T I]].

Written here (rather than taken from a library) because the manager needs the whole set of
tracks in one array operation; Stone Soup and FilterPy step one track at a time.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from arrayproc.errors import ConfigError


class BatchFilter(Protocol):
    """What :class:`~arrayproc.track.manage.manager.TrackManager` needs of a filter."""

    def predict(self, X: np.ndarray, P: np.ndarray, dt: np.ndarray, ctx: Any
                ) -> tuple[np.ndarray, np.ndarray]: ...

    def innovation(self, X: np.ndarray, P: np.ndarray, Z: np.ndarray, ctx: Any
                   ) -> tuple[np.ndarray, np.ndarray]: ...

    def update(self, X: np.ndarray, P: np.ndarray, Z: np.ndarray, ctx: Any, idx: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...


@dataclass(frozen=True)
class ConstantVelocity:
    """Nearly-constant-velocity motion in ``ndim`` axes; state [positions…, velocities…];
    ``q`` the acceleration noise spectral density (units²/s³)."""

    ndim: int
    q: float

    def __post_init__(self) -> None:
        if self.ndim < 1 or not self.q >= 0 or not math.isfinite(self.q):
            raise ConfigError("motion: need ndim >= 1 and a finite q >= 0")

    @property
    def dim(self) -> int:
        return 2 * self.ndim

    def matrices(self, dt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """F (n, d, d) and Q (n, d, d) for time steps ``dt`` (n,) s (BLK eq. 6.2.2-12)."""
        dt = np.asarray(dt, float).reshape(-1)
        k = self.ndim
        eye = np.eye(k)
        n = dt.size
        F = np.broadcast_to(np.eye(2 * k), (n, 2 * k, 2 * k)).copy()
        F[:, :k, k:] = dt[:, None, None] * eye
        Q = np.empty((n, 2 * k, 2 * k))
        Q[:, :k, :k] = (dt ** 3 / 3.0)[:, None, None] * eye
        Q[:, :k, k:] = (dt ** 2 / 2.0)[:, None, None] * eye
        Q[:, k:, :k] = Q[:, :k, k:]
        Q[:, k:, k:] = dt[:, None, None] * eye
        return F, self.q * Q


def _predict_cv(motion: ConstantVelocity, X: np.ndarray, P: np.ndarray, dt: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
    F, Q = motion.matrices(dt)
    Xp = np.einsum("nij,nj->ni", F, X)
    Pp = F @ P @ F.transpose(0, 2, 1) + Q
    return Xp, 0.5 * (Pp + Pp.transpose(0, 2, 1))


def _gain_update(X: np.ndarray, P: np.ndarray, nu: np.ndarray, H: np.ndarray, R: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Kalman update of stacked pairs: X (a, d), P (a, d, d), innovations nu (a, k), measurement
    Jacobians H (a, k, d), noise R (a, k, k). Joseph form; returns X, P and ln N(ν; 0, S)."""
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


def _pick(R: np.ndarray, idx: np.ndarray, k: int) -> np.ndarray:
    """Noise of the measurements ``idx``: R (k, k) shared or (m, k, k) per measurement."""
    return np.broadcast_to(R, (idx.size, k, k)) if R.ndim == 2 else R[idx]


def _noise(R: np.ndarray | Callable[[Any, int], np.ndarray], ctx: Any, m: int) -> np.ndarray:
    return np.asarray(R(ctx, m) if callable(R) else R, float)


class KalmanBatch:
    """Linear-Gaussian filter: CV motion ``motion``, measurement z = H x + w, w ~ N(0, R).

    ``R`` is a (k, k) matrix or a callable ``R(ctx, m)`` returning (k, k) or per-measurement
    (m, k, k) covariances (e.g. the ``cov`` column of ``positions`` rows)."""

    def __init__(self, motion: ConstantVelocity, H: np.ndarray,
                 R: np.ndarray | Callable[[Any, int], np.ndarray]) -> None:
        self.motion = motion
        self.H = np.asarray(H, float)
        self.R = R
        if self.H.ndim != 2 or self.H.shape[1] != motion.dim:
            raise ConfigError(f"kalman: H must be (k, {motion.dim})")

    def predict(self, X: np.ndarray, P: np.ndarray, dt: np.ndarray, ctx: Any = None
                ) -> tuple[np.ndarray, np.ndarray]:
        """Time update of all tracks (BLK eqs. 5.2.3-5, 5.2.3-7)."""
        return _predict_cv(self.motion, X, P, dt)

    def innovation(self, X: np.ndarray, P: np.ndarray, Z: np.ndarray, ctx: Any = None
                   ) -> tuple[np.ndarray, np.ndarray]:
        """ν (n, m, k) and S (n, k, k) or (n, m, k, k) of every pair (BLK eq. 5.2.3-9)."""
        Z = np.asarray(Z, float).reshape(-1, self.H.shape[0])
        H = self.H
        zh = X @ H.T
        nu = Z[None, :, :] - zh[:, None, :]
        R = _noise(self.R, ctx, Z.shape[0])
        HPH = H @ P @ H.T
        S = HPH if R.ndim == 2 else HPH[:, None]
        return nu, S + R

    def update(self, X: np.ndarray, P: np.ndarray, Z: np.ndarray, ctx: Any, idx: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Measurement update of pairs: tracks X (a, d), P (a, d, d) with measurements
        ``Z[idx]`` of the scan Z (m, k) (BLK eqs. 5.2.3-11 to 5.2.3-15). Returns X, P and the
        log-likelihoods ln N(ν; 0, S) (a,)."""
        k = self.H.shape[0]
        Z = np.asarray(Z, float).reshape(-1, k)
        idx = np.asarray(idx, np.int64)
        H = np.broadcast_to(self.H, (X.shape[0],) + self.H.shape)
        R = _pick(_noise(self.R, ctx, Z.shape[0]), idx, k)
        return _gain_update(X, P, Z[idx] - X @ self.H.T, H, R)


class MeasurementFunction(Protocol):
    """A nonlinear measurement model for :class:`EKFBatch`."""

    dim: int
    angles: tuple[int, ...]

    def h(self, X: np.ndarray, ctx: Any) -> np.ndarray: ...

    def jacobian(self, X: np.ndarray, ctx: Any) -> np.ndarray: ...

    def noise(self, ctx: Any, m: int) -> np.ndarray: ...


def wrap_angles(v: np.ndarray, angles: tuple[int, ...]) -> np.ndarray:
    """Wrap the components ``angles`` (radians) of the last axis of v to [−π, π)."""
    if angles:
        v = v.copy()
        idx = list(angles)
        v[..., idx] = (v[..., idx] + math.pi) % (2 * math.pi) - math.pi
    return v


class EKFBatch:
    """Extended Kalman filter (BLK 2001 sec. 10.3) with CV motion and a nonlinear measurement
    model offering ``h``, ``jacobian``, ``noise`` and the angular components ``angles``."""

    def __init__(self, motion: ConstantVelocity, model: MeasurementFunction) -> None:
        self.motion = motion
        self.model = model

    def predict(self, X: np.ndarray, P: np.ndarray, dt: np.ndarray, ctx: Any = None
                ) -> tuple[np.ndarray, np.ndarray]:
        return _predict_cv(self.motion, X, P, dt)

    def innovation(self, X: np.ndarray, P: np.ndarray, Z: np.ndarray, ctx: Any = None
                   ) -> tuple[np.ndarray, np.ndarray]:
        """ν (n, m, k) wrapped on angles, S = H P Hᵀ + R (n, k, k) or (n, m, k, k)."""
        k = self.model.dim
        Z = np.asarray(Z, float).reshape(-1, k)
        zh = self.model.h(X, ctx)
        H = self.model.jacobian(X, ctx)
        nu = wrap_angles(Z[None, :, :] - zh[:, None, :], self.model.angles)
        R = self.model.noise(ctx, Z.shape[0])
        HPH = H @ P @ H.transpose(0, 2, 1)
        return nu, (HPH + R if R.ndim == 2 else HPH[:, None] + R)

    def update(self, X: np.ndarray, P: np.ndarray, Z: np.ndarray, ctx: Any, idx: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """As :meth:`KalmanBatch.update`, linearised at the predicted states."""
        k = self.model.dim
        Z = np.asarray(Z, float).reshape(-1, k)
        idx = np.asarray(idx, np.int64)
        nu = wrap_angles(Z[idx] - self.model.h(X, ctx), self.model.angles)
        R = _pick(np.asarray(self.model.noise(ctx, Z.shape[0]), float), idx, k)
        return _gain_update(X, P, nu, self.model.jacobian(X, ctx), R)


__all__ = ["BatchFilter", "ConstantVelocity", "KalmanBatch", "EKFBatch", "wrap_angles",
           "MeasurementFunction"]
