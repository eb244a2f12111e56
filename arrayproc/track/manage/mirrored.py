"""Bearing tracks of a line array in true-bearing space with a mirrored (port/starboard) pair
of hypotheses per track (L-R paper eqs. (8)-(11) applied to the bearing / bearing-rate
filter).

A line array measures a cone angle θ; the target's true bearing is h + θ (starboard) or
h − θ (port) with h the array heading (L-R paper eq. (8): the ghost is the mirror 2h − β).
Each track carries both hypotheses, each a nearly-constant-bearing-rate filter (BLK 2001
eq. 6.2.2-12) on [β, β̇], and their log-weights. Association uses, for every
(track, measurement) pair, the hypothesis with the larger weighted likelihood; the update
feeds each hypothesis its member of the pair (port bearing to the port hypothesis, starboard
to starboard) and reweights them by their likelihoods (eqs. (9)-(11)). A target's true bearing
moves slowly through an ownship turn while its cone angle swings, so a track that coasts
through a turn without detections keeps its target; the ghost's weight collapses after the
turn.

State layout (n = 6): [β_s, β_p, β̇_s, β̇_p, ln w_s, ln w_p] (deg, deg/s); the covariance of
the last two components is unused (held at 1, no correlation). Measurements Z (m, 3):
[cone θ, port bearing, starboard bearing] (deg); R = (σ_θ / max(sin θ, s_min))² (beam
widening towards end-fire, thesis eq. 2.9). The predict context is the process-noise
multiplier of the scan (1 + (ḣ / ``turn_ref``)², larger during ownship turns, when the
array bends and the tow ship swings).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from arrayproc.track.models.motion import ConstantVelocity

LOG_FLOOR = math.log(1e-9)


def _wrap180(v: np.ndarray) -> np.ndarray:
    return (v + 180.0) % 360.0 - 180.0


class MirroredBearingBatch:
    """Batched filter of mirrored bearing hypotheses (see the module doc).

    Parameters
    ----------
    q : float
        Bearing-acceleration noise spectral density, deg²/s³.
    sigma_cone_deg : float
        Cone-angle noise at broadside, deg.
    min_sin : float
        Floor of sin θ in the noise widening.
    """

    def __init__(self, q: float, sigma_cone_deg: float, min_sin: float = 0.2) -> None:
        self.motion = ConstantVelocity(q1=float(q), axes=2)
        self.s0 = float(sigma_cone_deg)
        self.min_sin = float(min_sin)

    def noise(self, Z: np.ndarray) -> np.ndarray:
        """R (m,) deg² of each measurement."""
        s = self.s0 / np.maximum(np.sin(np.deg2rad(Z[:, 0])), self.min_sin)
        return s * s

    def predict(self, X: np.ndarray, P: np.ndarray, dt: np.ndarray, ctx: Any = 1.0
                ) -> tuple[np.ndarray, np.ndarray]:
        """CV prediction of both hypotheses; ``ctx`` multiplies Q."""
        F, Q = self.motion.transition_stacked(dt), self.motion.covariance_stacked(dt)
        X = X.copy()
        P = P.copy()
        X[:, :4] = np.einsum("nij,nj->ni", F, X[:, :4])
        Pk = F @ P[:, :4, :4] @ F.transpose(0, 2, 1) + float(ctx) * Q
        P[:, :4, :4] = 0.5 * (Pk + Pk.transpose(0, 2, 1))
        return X, P

    def _pairs(self, X: np.ndarray, P: np.ndarray, Z: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Innovations (n, m, 2) and variances (n, m, 2) of the starboard and port
        hypotheses, and their weighted log-likelihood scores (n, m, 2)."""
        R = self.noise(Z)
        nu = np.stack([_wrap180(Z[None, :, 2] - X[:, None, 0]),
                       _wrap180(Z[None, :, 1] - X[:, None, 1])], -1)
        S = np.stack([P[:, 0, 0][:, None] + R[None, :], P[:, 1, 1][:, None] + R[None, :]], -1)
        ll = -0.5 * (nu * nu / S + np.log(2 * math.pi * S))
        return nu, S, ll + X[:, None, 4:6]

    def innovation(self, X: np.ndarray, P: np.ndarray, Z: np.ndarray, ctx: Any = None
                   ) -> tuple[np.ndarray, np.ndarray]:
        """ν (n, m, 1) and S (n, m, 1, 1) of the better hypothesis of each pair."""
        Z = np.asarray(Z, float).reshape(-1, 3)
        nu, S, score = self._pairs(X, P, Z)
        h = np.argmax(score, axis=-1)[..., None]
        return (np.take_along_axis(nu, h, -1),
                np.take_along_axis(S, h, -1)[..., None])

    def update(self, X: np.ndarray, P: np.ndarray, Z: np.ndarray, ctx: Any, idx: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Each hypothesis updated with its member of measurement ``idx``; weights by the
        likelihoods (L-R eqs. (9)-(11)); returns X, P and the mixture log-likelihood."""
        Z = np.asarray(Z, float).reshape(-1, 3)[np.asarray(idx, np.int64)]
        R = self.noise(Z)
        X = X.copy()
        P = P.copy()
        lls = np.empty((X.shape[0], 2))
        for h, (b, col) in enumerate(((0, 2), (1, 1))):
            r = 2 + h
            nu = _wrap180(Z[:, col] - X[:, b])
            S = P[:, b, b] + R
            K = P[:, [b, r], b] / S[:, None]  # gain on [β, β̇] of this hypothesis
            X[:, b] += K[:, 0] * nu
            X[:, r] += K[:, 1] * nu
            idx2 = np.array([b, r])
            Pb = P[:, idx2][:, :, idx2]
            Pb = Pb - K[:, :, None] * K[:, None, :] * S[:, None, None]
            P[:, idx2[:, None], idx2[None, :]] = 0.5 * (Pb + Pb.transpose(0, 2, 1))
            lls[:, h] = -0.5 * (nu * nu / S + np.log(2 * math.pi * S))
        lw = X[:, 4:6] + lls
        mx = lw.max(1, keepdims=True)
        tot = mx[:, 0] + np.log(np.exp(lw - mx).sum(1))
        X[:, 4:6] = np.maximum(lw - tot[:, None], LOG_FLOOR)
        return X, P, tot  # ln Σ_h w_h p_h, the mixture likelihood

    @staticmethod
    def initial(Z: np.ndarray, j: int, s0: float, min_sin: float, sigma_rate: float
                ) -> tuple[np.ndarray, np.ndarray]:
        """Track from measurement j: both hypotheses at their members, rates 0 ± σ_rate,
        equal weights."""
        s = s0 / max(math.sin(math.radians(float(Z[j, 0]))), min_sin)
        x = np.array([Z[j, 2], Z[j, 1], 0.0, 0.0, math.log(0.5), math.log(0.5)])
        return x, np.diag([s * s, s * s, sigma_rate ** 2, sigma_rate ** 2, 1.0, 1.0])

    @staticmethod
    def cone(X: np.ndarray, P: np.ndarray, heading_deg: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Cone angle (deg) and its σ of the dominant hypothesis, and the starboard weight,
        for states X (n, 6) at array headings (n,) deg."""
        stbd = X[:, 4] >= X[:, 5]
        b = np.where(stbd, X[:, 0], X[:, 1])
        var = np.where(stbd, P[:, 0, 0], P[:, 1, 1])
        w = np.exp(X[:, 4:6])
        ws = w[:, 0] / w.sum(1)
        return np.abs(_wrap180(b - heading_deg)), np.sqrt(np.clip(var, 0, None)), ws


__all__ = ["MirroredBearingBatch"]
