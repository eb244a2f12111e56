"""Left-right ambiguity resolution with two parallel filters (L-R paper section III).

One filter per member of the port/starboard bearing pair, weights from the measurement
likelihoods (eqs. (9)-(11)), combined estimate and covariance (eqs. (12)-(13)). Works with any
filter object offering ``x``, ``P``, ``predict(T, own_prev, own_next)`` and
``update(bearing_deg) -> log-likelihood`` (see :mod:`arrayproc.track.filters`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from arrayproc.track.filters import FilterDivergence


class LRResolver:
    """Two-hypothesis L-R tracker over filters ``filters`` (one per side), equal initial
    weights ω¹ = ω² = 1/2 (section III)."""

    def __init__(self, filters: Sequence) -> None:
        self.filters = list(filters)
        m = len(self.filters)
        self.logw = np.full(m, -math.log(m))
        self.alive = np.ones(m, dtype=bool)

    @property
    def weights(self) -> np.ndarray:
        """ω_k^h, eqs. (10)-(11)."""
        return np.where(self.alive, np.exp(self.logw), 0.0)

    def step(self, T: float, own_prev: np.ndarray, own_next: np.ndarray,
             bearings_deg: Sequence[float], level_db: float | None = None) -> None:
        """Predict every hypothesis, update hypothesis h with ``bearings_deg[h]`` (and the
        received level ``level_db``, dB re 1 µPa, for filters that use levels) and reweight:
        ω_k^h ∝ p_k^h ω_{k−1}^h (eqs. (9)-(11)). A diverged hypothesis gets weight zero."""
        for h, f in enumerate(self.filters):
            if not self.alive[h]:
                continue
            try:
                f.predict(T, own_prev, own_next)
                self.logw[h] += (f.update(bearings_deg[h]) if level_db is None
                                 else f.update(bearings_deg[h], level_db))
            except FilterDivergence:
                self.alive[h] = False
        if not self.alive.any():
            raise FilterDivergence("lr: every hypothesis diverged")
        lw = np.where(self.alive, self.logw, -np.inf)
        mx = lw.max()
        self.logw = lw - (mx + math.log(np.exp(lw - mx).sum()))

    def estimate(self) -> tuple[np.ndarray, np.ndarray]:
        """Combined state (eq. (12)) and covariance (eq. (13))."""
        w = self.weights
        xs = np.array([f.x for f in self.filters])
        x = w @ xs
        P = np.zeros((x.size, x.size))
        for wh, f in zip(w, self.filters, strict=True):
            if wh > 0:
                d = f.x - x
                P += wh * (f.P + np.outer(d, d))
        return x, P
