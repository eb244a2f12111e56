"""Heading jitter of a rigid array: a first-order Gauss-Markov (Ornstein-Uhlenbeck) yaw.

The array's true heading is the ownship's plus ψ(t), with ``E ψ = 0`` and
``E ψ(t) ψ(t + Δ) = σ² exp(−|Δ|/τ)`` (σ = ``[array] yaw_std``, τ = ``yaw_time``), the
exponentially correlated bearing error of the compact-array paper's covariance
``C_ij = σ² exp(−|t_i − t_j|/τ)``. ``/nav`` keeps the nominal heading, so every bearing the
chain measures carries the error −ψ at its time.

ψ is drawn on an absolute grid of step ``δ = min(0.25 s, τ/80)`` from t = 0 by the exact
discretisation ``ψ_k = φ ψ_{k−1} + σ √(1 − φ²) ξ_k`` with ``φ = exp(−δ/τ)`` and
``ψ_0 ~ N(0, σ²)`` (stationary from the start), one seeded stream, and interpolated
linearly in between (the variance midway between nodes is ``σ² (1 + φ)/2``, at most 0.6 %
low). The grid depends on the duration only, so the samples do not depend on the chunk size.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.signal import lfilter

__all__ = ["GaussMarkovYaw", "yaw_step"]


def yaw_step(yaw_time: float) -> float:
    """Grid step δ (s) of the yaw: min(0.25 s, τ/80)."""
    return min(0.25, float(yaw_time) / 80.0)


class GaussMarkovYaw:
    """Seeded yaw ψ(t) (deg) of std ``yaw_std`` and correlation time ``yaw_time``.

    Parameters
    ----------
    yaw_std : float
        σ (deg), > 0.
    yaw_time : float
        τ (s), > 0.
    duration : float
        Covers [0, duration] s (times outside are held at the end nodes).
    seed : numpy.random.SeedSequence
        The stream of the draws.
    """

    def __init__(self, yaw_std: float, yaw_time: float, duration: float,
                 seed: np.random.SeedSequence) -> None:
        self.sigma = float(yaw_std)
        self.tau = float(yaw_time)
        self.step = yaw_step(self.tau)
        n = int(math.ceil(float(duration) / self.step)) + 2
        self.time = self.step * np.arange(n)
        rng = np.random.default_rng(seed)
        xi = rng.standard_normal(n)
        phi = math.exp(-self.step / self.tau)
        drive = self.sigma * math.sqrt(1.0 - phi * phi) * xi
        drive[0] = self.sigma * xi[0]  # ψ_0 from the stationary law
        self.values = lfilter([1.0], [1.0, -phi], drive)

    def __call__(self, t: np.ndarray) -> np.ndarray:
        """ψ (deg) at times ``t`` (s)."""
        return np.interp(np.asarray(t, float), self.time, self.values)
