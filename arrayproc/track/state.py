"""Track states and the observer context handed to every model and filter.

The state is the *relative* target state of the L-R paper eq. (1), ``X = X^t − X^o``:
``[x, y, ẋ, ẏ]`` (m, m/s) or ``[x, y, ẋ, ẏ, ψ]`` with the turn rate ψ (rad/s, CT model);
x east, y north. :class:`Context` carries what the models need about the observer.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["Context", "GaussianState", "ParticleState"]


@dataclass
class Context:
    """Observer context of one step.

    ``own`` is the observer state [x, y, ẋ, ẏ] (m, m/s) at the measurement time, ``own_prev``
    at the previous time (motion models use both, L-R paper eqs. (1)-(3)); ``heading`` the array
    heading (rad, clockwise from north; mirrored bearings, L-R paper eq. (8)); ``t`` the time (s).
    ``meas_cov`` and ``q_scale`` are the scan's measurement covariances and process-noise
    multiplier for the stacked (multi-target) filters.
    """

    own: np.ndarray
    own_prev: np.ndarray | None = None
    heading: float = 0.0
    t: float = 0.0
    #: per-measurement noise covariances (m, k, k) of a scan whose rows carry their own
    #: (the ``cov`` column of ``positions``), read by the models that need them
    meas_cov: np.ndarray | None = None
    #: multiplier of the process noise Q over this step (e.g. larger during ownship turns)
    q_scale: float = 1.0

    def __post_init__(self) -> None:
        self.own = np.ascontiguousarray(self.own, dtype=float)
        if self.own_prev is None:
            self.own_prev = self.own
        else:
            self.own_prev = np.ascontiguousarray(self.own_prev, dtype=float)


@dataclass
class GaussianState:
    """Mean ``x`` (n,) and covariance ``P`` (n, n) of the relative state at time ``t`` (s)."""

    x: np.ndarray
    P: np.ndarray
    t: float = 0.0

    def __post_init__(self) -> None:
        self.x = np.array(self.x, dtype=float).reshape(-1)
        self.P = np.array(self.P, dtype=float).reshape(self.x.size, self.x.size)

    @property
    def ndim(self) -> int:
        return int(self.x.size)


@dataclass
class ParticleState:
    """A weighted particle cloud of the relative state at time ``t``.

    ``particles`` (N, n); ``weights`` (N,) unnormalised with their sum ``weight_sum`` (the
    regularized particle filter keeps them so, SPL paper eqs. (18)-(19)); ``rng`` the uint64[1]
    state of the cloud's random stream; ``x``, ``P`` the weighted mean and covariance
    (SPL paper eqs. (29)-(30)).
    """

    particles: np.ndarray
    weights: np.ndarray
    weight_sum: float
    rng: np.ndarray
    x: np.ndarray = field(default_factory=lambda: np.zeros(4))
    P: np.ndarray = field(default_factory=lambda: np.eye(4))
    t: float = 0.0
    n_resampled: int = 0

    @property
    def ndim(self) -> int:
        return int(self.particles.shape[1])
