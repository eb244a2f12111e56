"""Motion models of the L-R paper (Das, Tiwari & Bhaumik), section II, as objects.

State: the *relative* target state ``X = X^t − X^o`` (eq. (1)), ``[x, y, ẋ, ẏ]`` for the
constant-velocity model (eqs. (2)-(4)) and ``[x, y, ẋ, ẏ, ψ]`` for the constant-turn model
(eqs. (5)-(6), ψ the unknown turn rate, rad/s, positive anticlockwise as in eq. (5)). SI units
and radians. The numba kernels are in :mod:`arrayproc.track.models._kernels`.
"""

from __future__ import annotations

import numpy as np

from arrayproc.errors import ConfigError
from arrayproc.track.base import Param
from arrayproc.track.models import _kernels as km
from arrayproc.track.models.base import MotionModel
from arrayproc.track.state import Context

__all__ = ["ConstantVelocity", "ConstantTurn", "Q1_PAPER", "Q2_PAPER", "make_model",
           "constant_velocity", "constant_turn", "MOTION_MODELS"]

# L-R paper section V: q̄1 = 1.944e-6 km²/min³, q̄2 = 3.78e-7 min⁻³, converted to SI.
Q1_PAPER = 1.944e-6 * 1e6 / 60.0**3  # m²/s³
Q2_PAPER = 3.78e-7 / 60.0**3  # rad²/s³


def _nonneg(v: float) -> str | None:
    return None if v >= 0 else "must be >= 0"


class ConstantVelocity(MotionModel):
    """Constant velocity, L-R paper eqs. (2)-(4): ``q1`` (m²/s³) is the acceleration noise
    intensity q̄1 of eq. (4).

    ``axes`` is the number of position axes: state [positions…, velocities…] (2: the relative
    state [x, y, ẋ, ẏ] of eq. (1); 1 or 3 for stacked tracks of a bearing or a 3-D position).
    The one-track form (``function_points``, ``jacobian``, ``covariance``) has 2 axes; the
    stacked form (:meth:`transition_stacked`, :meth:`covariance_stacked`, stacked tracks in
    world coordinates) any number: F = [[I, T I], [0, I]],
    Q = q̄1 [[T³/3 I, T²/2 I], [T²/2 I, T I]] (eqs. (2), (4); Bar-Shalom, Li & Kirubarajan
    2001 eq. 6.2.2-12).
    """

    name = "cv"
    linear = True
    params = {"q1": Param("float", Q1_PAPER, "acceleration noise intensity, m²/s³",
                          check=_nonneg),
              "axes": Param("int", 2, "position axes (state [positions, velocities])",
                            check=lambda v: None if v >= 1 else "must be >= 1")}

    @property
    def ndim(self) -> int:  # type: ignore[override]
        return 2 * self.axes

    @property
    def q2(self) -> float:
        return 0.0

    def transition_stacked(self, dt: np.ndarray) -> np.ndarray:
        """F (n, d, d) for time steps ``dt`` (n,) s (eq. (2))."""
        dt = np.asarray(dt, float).reshape(-1)
        k = self.axes
        F = np.broadcast_to(np.eye(2 * k), (dt.size, 2 * k, 2 * k)).copy()
        F[:, :k, k:] = dt[:, None, None] * np.eye(k)
        return F

    def covariance_stacked(self, dt: np.ndarray) -> np.ndarray:
        """Q (n, d, d) for time steps ``dt`` (n,) s (eq. (4))."""
        dt = np.asarray(dt, float).reshape(-1)
        k = self.axes
        eye = np.eye(k)
        Q = np.empty((dt.size, 2 * k, 2 * k))
        Q[:, :k, :k] = (dt ** 3 / 3.0)[:, None, None] * eye
        Q[:, :k, k:] = (dt ** 2 / 2.0)[:, None, None] * eye
        Q[:, k:, :k] = Q[:, :k, k:]
        Q[:, k:, k:] = dt[:, None, None] * eye
        return self.q1 * Q

    def function_points(self, X, dt, ctx, out) -> None:
        if self.axes != 2:
            raise ConfigError("cv: the one-track (relative-state) form has axes = 2")
        km.cv_propagate_points(X, float(dt), ctx.own_prev, ctx.own, out)

    def jacobian(self, x: np.ndarray, dt: float, ctx: Context | None = None) -> np.ndarray:
        """Eq. (2)."""
        F = np.empty((4, 4))
        km.cv_jacobian(float(dt), F)
        return F

    def covariance(self, dt: float) -> np.ndarray:
        """Eq. (4)."""
        Q = np.empty((4, 4))
        km.white_acceleration_noise(float(dt), self.q1, 0.0, Q)
        return Q


class ConstantTurn(MotionModel):
    """Constant turn with unknown turn rate, L-R paper eqs. (5)-(6): ``q1`` (m²/s³) as for CV,
    ``q2`` (rad²/s³) the turn-rate noise intensity q̄2 of eq. (6)."""

    name = "ct"
    ndim = 5
    params = {"q1": Param("float", Q1_PAPER, "acceleration noise intensity, m²/s³",
                          check=_nonneg),
              "q2": Param("float", Q2_PAPER, "turn-rate noise intensity, rad²/s³",
                          check=_nonneg)}

    def function_points(self, X, dt, ctx, out) -> None:
        km.ct_propagate_points(X, float(dt), ctx.own_prev, ctx.own, out)

    def jacobian(self, x: np.ndarray, dt: float, ctx: Context) -> np.ndarray:
        """Eq. (5) with the ψ column."""
        F = np.empty((5, 5))
        km.ct_jacobian(np.ascontiguousarray(x, dtype=float), float(dt), ctx.own_prev, F)
        return F

    def covariance(self, dt: float) -> np.ndarray:
        """Eq. (6)."""
        Q = np.empty((5, 5))
        km.white_acceleration_noise(float(dt), self.q1, self.q2, Q)
        return Q


MOTION_MODELS: dict[str, type[MotionModel]] = {"cv": ConstantVelocity, "ct": ConstantTurn}


def constant_velocity(q1: float = Q1_PAPER) -> ConstantVelocity:
    """Constant-velocity model, L-R paper eqs. (2)-(4)."""
    return ConstantVelocity(q1=float(q1))


def constant_turn(q1: float = Q1_PAPER, q2: float = Q2_PAPER) -> ConstantTurn:
    """Constant-turn model with unknown turn rate, L-R paper eqs. (5)-(6)."""
    return ConstantTurn(q1=float(q1), q2=float(q2))


def make_model(name: str, q1: float = Q1_PAPER, q2: float = Q2_PAPER) -> MotionModel:
    """Motion model from its configuration name ``"cv"`` or ``"ct"``.

    Parameters
    ----------
    name : str
        ``"cv"`` (eqs. (2)-(4)) or ``"ct"`` (eqs. (5)-(6)).
    q1, q2 : float
        Noise intensities, m²/s³ and rad²/s³ (q2 for CT only).

    Returns
    -------
    MotionModel
    """
    if name == "cv":
        return constant_velocity(q1)
    if name == "ct":
        return constant_turn(q1, q2)
    raise ConfigError(f"tracker: model must be 'cv' or 'ct', not {name!r}")
