"""Motion and measurement models of the L-R paper (Das, Tiwari & Bhaumik), section II.

State: the *relative* target state ``X = X^t − X^o`` (eq. (1)), ``[x, y, ẋ, ẏ]`` for the
constant-velocity model (eqs. (2)-(4)) and ``[x, y, ẋ, ẏ, ψ]`` for the constant-turn model
(eqs. (5)-(6), ψ the unknown turn rate, rad/s, positive anticlockwise as in eq. (5)). SI units
and radians inside; the public bearing helpers take and return degrees.

Bearings follow the papers' convention: clockwise from north, ``γ(X) = atan2(x, y)`` (eq. (7));
the mirror bearing about the array heading h is ``2h − θ`` (eq. (8)).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from arrayproc.errors import ConfigError
from arrayproc.geo.kinematics import wrap_pi
from arrayproc.track import _kernels as kc


@dataclass(frozen=True)
class MotionModel:
    """A relative-state motion model with its process-noise intensities.

    ``q1`` (m²/s³) is the acceleration noise intensity q̄1 of eq. (4); ``q2`` (rad²/s³) the
    turn-rate noise intensity q̄2 of eq. (6) (CT only).
    """

    name: str
    q1: float
    q2: float = 0.0

    @property
    def code(self) -> int:
        return kc.MODEL_CV if self.name == "cv" else kc.MODEL_CT

    @property
    def dim(self) -> int:
        return 4 if self.name == "cv" else 5

    def transition(self, x: np.ndarray, T: float, own_prev: np.ndarray,
                   own_next: np.ndarray) -> np.ndarray:
        """X_k = f(X_{k−1}) − ℧_{k−1,k} (eq. (1) with eq. (2)-(3) or (5)); own_* = [x, y, ẋ, ẏ]."""
        out = np.empty(self.dim)
        kc.propagate(self.code, np.asarray(x, float), float(T), np.asarray(own_prev, float),
                     np.asarray(own_next, float), out)
        return out

    def jacobian(self, x: np.ndarray, T: float, own_prev: np.ndarray) -> np.ndarray:
        """∂f/∂X: eq. (2) for CV, eq. (5) with the ψ column for CT."""
        F = np.empty((self.dim, self.dim))
        kc.transition_jacobian(self.code, np.asarray(x, float), float(T),
                               np.asarray(own_prev, float), F)
        return F

    def process_noise(self, T: float) -> np.ndarray:
        """Q of eq. (4) (CV) or eq. (6) (CT)."""
        Q = np.empty((self.dim, self.dim))
        kc.process_noise(self.code, float(T), self.q1, self.q2, Q)
        return Q


# L-R paper section V: q̄1 = 1.944e-6 km²/min³, q̄2 = 3.78e-7 min⁻³, converted to SI.
Q1_PAPER = 1.944e-6 * 1e6 / 60.0**3  # m²/s³
Q2_PAPER = 3.78e-7 / 60.0**3  # rad²/s³


def constant_velocity(q1: float = Q1_PAPER) -> MotionModel:
    """Constant-velocity model, L-R paper eqs. (2)-(4)."""
    return MotionModel("cv", float(q1))


def constant_turn(q1: float = Q1_PAPER, q2: float = Q2_PAPER) -> MotionModel:
    """Constant-turn model with unknown turn rate, L-R paper eqs. (5)-(6)."""
    return MotionModel("ct", float(q1), float(q2))


def make_model(name: str, q1: float = Q1_PAPER, q2: float = Q2_PAPER) -> MotionModel:
    if name == "cv":
        return constant_velocity(q1)
    if name == "ct":
        return constant_turn(q1, q2)
    raise ConfigError(f"tracker: model must be 'cv' or 'ct', not {name!r}")


def bearing_rad(x: np.ndarray) -> np.ndarray:
    """γ(X) = atan2(x, y), rad in [−π, π), for states of shape (..., n) (eq. (7))."""
    x = np.asarray(x, float)
    return np.arctan2(x[..., 0], x[..., 1])


def bearing_deg(x: np.ndarray) -> np.ndarray:
    """Bearing of eq. (7) in degrees clockwise from north, in [0, 360)."""
    return np.mod(np.rad2deg(bearing_rad(x)), 360.0)


def mirror_bearing_deg(bearing: np.ndarray | float, heading: np.ndarray | float) -> np.ndarray:
    """Ghost bearing θ_g = 2h − θ about the array heading h (eq. (8)), degrees in [0, 360)."""
    return np.mod(2.0 * np.asarray(heading, float) - np.asarray(bearing, float), 360.0)


def port_starboard(bearing_rad_: np.ndarray, heading_rad: np.ndarray) -> tuple[np.ndarray,
                                                                                  np.ndarray,
                                                                                  np.ndarray]:
    """Split a (true) bearing and its eq.-(8) mirror into the port and starboard members of the
    pair a line array reports. Returns (port, starboard, true_is_starboard), radians."""
    d = wrap_pi(np.asarray(bearing_rad_, float) - heading_rad)
    cone = np.abs(d)
    port = wrap_pi(heading_rad - cone)
    stbd = wrap_pi(heading_rad + cone)
    return port, stbd, d >= 0.0


def bearing_sigma_mean(sigmas: np.ndarray, wm: np.ndarray) -> np.ndarray:
    """Weighted mean of sigma-point bearings (rad, first column), unwrapped about the first
    point — the rule our UKF uses; a ``z_mean_fn`` for other UKF libraries (filterpy)."""
    z = np.asarray(sigmas)[:, 0]
    return np.array([wrap_pi(z[0] + np.dot(wm, wrap_pi(z - z[0])))])


def bearing_residual(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Bearing difference wrapped to [−π, π) (a ``residual_z`` for other UKF libraries)."""
    return wrap_pi(np.asarray(a) - np.asarray(b))
