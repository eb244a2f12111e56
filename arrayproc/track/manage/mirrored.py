"""Bearing tracks of a line array in true-bearing space: a mirrored (port/starboard) pair of
hypotheses per track (L-R paper eqs. (8)-(11) applied to the bearing / bearing-rate filter),
run by the hypothesis bank (:class:`~arrayproc.track.manage.bank.StackedBank`).

A line array measures a cone angle θ; the target's true bearing is h + θ (starboard) or
h − θ (port) with h the array heading (L-R paper eq. (8): the ghost is the mirror 2h − β).
Each track carries both hypotheses, each a nearly-constant-bearing-rate filter on [β, β̇]
(:class:`~arrayproc.track.models.motion.ConstantVelocity` with one axis, the stacked EKF of
:mod:`arrayproc.track.filters.stacked` with the :class:`~arrayproc.track.models.position.
BearingDeg` model), and their log-weights (the track's ``logw``). Association uses, for every
(track, measurement) pair, the hypothesis with the larger weighted likelihood; the update
feeds each hypothesis its member of the pair (port bearing to the port hypothesis, starboard
to starboard) and reweights them by their likelihoods (eqs. (9)-(11)), the ghost's weight
floored at 1e-9 so that it can come back. A target's true bearing moves slowly through an
ownship turn while its cone angle swings, so a track that coasts through a turn without
detections keeps its target; the ghost's weight collapses after the turn.

State layout (n = 4, the bank's interleaving): [β_s, β_p, β̇_s, β̇_p] (deg, deg/s).
Measurements Z (m, 3): [cone θ, port bearing, starboard bearing] (deg);
R = (σ_θ / max(sin θ, s_min))² (beam widening towards end-fire, thesis eq. 2.9). The scan
context's ``q_scale`` multiplies Q (1 + (ḣ / ``turn_ref``)², larger during ownship turns,
when the array bends and the tow ship swings).
"""

from __future__ import annotations

import math

import numpy as np

from arrayproc.track.filters.stacked import StackedEKF
from arrayproc.track.manage.bank import StackedBank
from arrayproc.track.models.motion import ConstantVelocity
from arrayproc.track.models.position import BearingDeg, ConeAngle

LOG_FLOOR = math.log(1e-9)

__all__ = ["mirrored_bank", "mirrored_initial", "mirrored_cone", "LOG_FLOOR"]


def _members(Z: np.ndarray) -> np.ndarray:
    """Member of each hypothesis: starboard bearing (column 2) for h = 0, port (1) for h = 1."""
    return np.asarray(Z, float).reshape(-1, 3)[:, [2, 1]][:, :, None]


def mirrored_bank(q: float, sigma_cone_deg: float, min_sin: float = 0.2) -> StackedBank:
    """The bank of mirrored bearing hypotheses.

    Parameters
    ----------
    q : float
        Bearing-acceleration noise spectral density, deg²/s³.
    sigma_cone_deg : float
        Cone-angle noise at broadside, deg.
    min_sin : float
        Floor of sin θ in the noise widening.
    """
    cone = ConeAngle(sigma_deg=float(sigma_cone_deg), min_sin=float(min_sin))
    return StackedBank(StackedEKF(ConstantVelocity(q1=float(q), axes=1), BearingDeg()), 2,
                       _members, lambda Z: cone.noise_stacked(np.asarray(Z, float), None),
                       floor=LOG_FLOOR)


def mirrored_initial(Z: np.ndarray, j: int, s0: float, min_sin: float, sigma_rate: float
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Track from measurement j: both hypotheses at their members, rates 0 ± σ_rate, equal
    weights; returns x, P and the log-weights."""
    s = s0 / max(math.sin(math.radians(float(Z[j, 0]))), min_sin)
    x = np.array([Z[j, 2], Z[j, 1], 0.0, 0.0])
    return (x, np.diag([s * s, s * s, sigma_rate ** 2, sigma_rate ** 2]),
            np.full(2, math.log(0.5)))


def mirrored_cone(bank: StackedBank, X: np.ndarray, P: np.ndarray, W: np.ndarray,
                  heading_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Cone angle (deg) and its σ of the dominant hypothesis (the per-side estimate), and the
    starboard weight, for states X (n, 4), P, log-weights W (n, 2) at array headings (n,)
    deg."""
    xh, Ph, w = bank.dominant(X, P, W)
    cone = np.abs((xh[:, 0] - heading_deg + 180.0) % 360.0 - 180.0)
    return cone, np.sqrt(np.clip(Ph[:, 0, 0], 0, None)), w[:, 0]
