"""Unsteady tonals: random-walk phase (finite coherence time) and amplitude fading, as
seeded first-order Markov processes on a grid of source samples, chunk-independent.

A process x_j lives on the nodes j of a grid every ``NODE`` source samples (sample m = j·NODE)
and follows

    x_{j+1} = ρ·x_j + β·w_j,   w_j ~ N(0, 1),

forwards from node 0 and, with its own draws, backwards from it (for emission times before the
recording's start, which retarded times need). Between nodes the value is linear.

- Random-walk phase (Wiener process): ρ = 1, β = √(2Δ/T_c), x_0 = 0, Δ the node spacing
  (s). Then E[exp(i(φ(t+τ) − φ(t)))] = exp(−|τ|/T_c): the tonal's coherence decays to 1/e at
  the coherence time T_c (a Lorentzian line of half-power full width 1/(π T_c)).
- Fading (log-amplitude Gauss-Markov): ρ = exp(−Δ/T_f), β = σ√(1 − ρ²), x_0 ~ N(0, σ²);
  the amplitude gain 10^{x/20}·exp(−(σ ln10/20)²) keeps the mean power (σ in dB).

The increments of frame k (``FRAME`` nodes) come from ``SeedSequence(seed, key + (k + off,))``
and the state at every frame boundary is kept once computed, so a value never depends on how
the caller chunks its requests. Hand-written: no library offers seeded, random-access Markov
processes keyed by absolute index.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

from arrayproc.sim.signals import KEY_OFFSET

NODE = 16  # source samples between grid nodes
FRAME = 4096  # nodes per random frame


class MarkovGrid:
    """x_j on integer nodes j (any sign) of an AR(1) process, seeded per frame."""

    def __init__(self, rho: float, beta: float, x0: float, seed: int,
                 key: tuple[int, ...]) -> None:
        self.rho, self.beta = float(rho), float(beta)
        self.seed, self.key = int(seed), tuple(int(k) for k in key)
        self._start = {0: float(x0)}  # state at node k·FRAME (frames k >= 0), or at (k+1)·FRAME
        self._cache: dict[int, np.ndarray] = {}

    def _draws(self, k: int) -> np.ndarray:
        ss = np.random.SeedSequence(self.seed, spawn_key=self.key + (k + KEY_OFFSET,))
        return np.random.default_rng(ss).standard_normal(FRAME)

    def _frame(self, k: int) -> np.ndarray:
        """Values at nodes [k·FRAME, (k+1)·FRAME)."""
        y = self._cache.get(k)
        if y is not None:
            return y
        if k >= 0:
            x_start = self._boundary(k)
            w = self._draws(k)[:FRAME - 1]
            rest = lfilter([self.beta], [1.0, -self.rho], w, zi=[self.rho * x_start])[0]
            y = np.concatenate([[x_start], rest])
        else:  # backwards from node (k+1)·FRAME
            x_end = self._boundary(k + 1)
            w = self._draws(k)
            back = lfilter([self.beta], [1.0, -self.rho], w, zi=[self.rho * x_end])[0]
            y = back[::-1]
        if len(self._cache) > 8:
            self._cache.pop(next(iter(self._cache)))
        self._cache[k] = y
        return y

    def _boundary(self, k: int) -> float:
        """State at node k·FRAME, computed outwards from node 0 once and kept."""
        if k in self._start:
            return self._start[k]
        step = 1 if k > 0 else -1
        j = 0
        while j + step in self._start:
            j += step
        while j != k:
            if step > 0:  # the node after frame j's last
                w = self._draws(j)
                y = self._frame(j)
                self._start[j + 1] = self.rho * y[-1] + self.beta * w[FRAME - 1]
            else:  # frame j − 1 runs backwards from node j·FRAME to (j − 1)·FRAME
                self._start[j - 1] = float(self._frame(j - 1)[0])
            j += step
        return self._start[k]

    def nodes(self, j0: int, j1: int) -> np.ndarray:
        """Values at nodes j0 … j1 (inclusive)."""
        out = np.empty(j1 - j0 + 1)
        j = j0
        while j <= j1:
            k = j // FRAME
            f = self._frame(k)
            a = j - k * FRAME
            b = min(FRAME, j1 - k * FRAME + 1)
            out[j - j0: j - j0 + b - a] = f[a:b]
            j += b - a
        return out

    def at_samples(self, m0: int, m1: int) -> np.ndarray:
        """Linear interpolation between nodes at source samples m0 … m1 − 1."""
        j0 = m0 // NODE
        j1 = (m1 - 1) // NODE + 1
        x = self.nodes(j0, j1)
        u = (np.arange(m0, m1) - j0 * NODE) / NODE
        i = np.minimum(u.astype(np.int64), x.size - 2)
        return x[i] + (u - i) * (x[i + 1] - x[i])


def random_walk_phase(coherence_time: float, fs_src: float, seed: int,
                      key: tuple[int, ...]) -> MarkovGrid:
    """Wiener phase with E[exp(iΔφ(τ))] = exp(−|τ|/T_c)."""
    dt = NODE / fs_src
    return MarkovGrid(1.0, np.sqrt(2.0 * dt / coherence_time), 0.0, seed, key)


def fading_gain(std_db: float, corr_time: float, fs_src: float, seed: int,
                key: tuple[int, ...]) -> tuple[MarkovGrid, float]:
    """(log-amplitude process in dB, normalisation) of a mean-power-preserving fade."""
    dt = NODE / fs_src
    rho = float(np.exp(-dt / corr_time))
    x0 = float(np.random.default_rng(np.random.SeedSequence(seed, spawn_key=key + (0,)))
               .normal(0.0, std_db))
    norm = float(np.exp(-(std_db * np.log(10) / 20.0) ** 2))
    return MarkovGrid(rho, std_db * np.sqrt(1 - rho * rho), x0, seed, key + (1,)), norm
