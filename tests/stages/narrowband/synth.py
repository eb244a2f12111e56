"""Direct plane-wave synthesis for the narrowband tests: a unit tonal from cone θ on a line
array moving at U, as the filter's model sees it (thesis eq. (3.18)), plus white noise."""

from __future__ import annotations

import math

import numpy as np

C = 1500.0


def line(n: int = 64, spacing: float = 0.36) -> np.ndarray:
    """Element x positions (m), element 0 forward."""
    return -np.arange(n) * spacing


def tonal(t: np.ndarray, x: np.ndarray, cone_deg, freq, speed: float, snr_db: float,
          seed: int, fc: float | None = None, phase0: float = 0.7,
          spatial_doppler: bool = True) -> np.ndarray:
    """(T, N) samples: sin (real) or exp(j(Φ − 2π fc t)) (complex baseband) of the received
    phase Φ = 2π ∫ f_D dt + 2π f_D x cos θ / c with cone and frequency constant or (T,)
    arrays, plus noise at per-element SNR ``snr_db`` (power ratio). ``spatial_doppler``: the
    element delay term with f_D as thesis eq. (3.18); False: with f (the exact plane-wave
    phase of a moving array)."""
    cone = np.broadcast_to(np.radians(cone_deg), t.shape)
    f = np.broadcast_to(np.asarray(freq, float), t.shape)
    fd = f * (1 + speed * np.cos(cone) / C)
    dt = t[1] - t[0]
    ph_t = 2 * np.pi * np.concatenate([[0.0], np.cumsum(0.5 * (fd[1:] + fd[:-1]) * dt)])
    fx = fd if spatial_doppler else f
    ph = (ph_t + 2 * np.pi * fd * t[0])[:, None] + 2 * np.pi * (fx * np.cos(cone) / C)[:, None] \
        * x[None, :] + phase0
    rng = np.random.default_rng(seed)
    if fc is None:
        y = np.sin(ph)
        sig_p = 0.5
        return y + math.sqrt(sig_p / 10 ** (snr_db / 10)) * rng.standard_normal(y.shape)
    y = np.exp(1j * (ph - 2 * np.pi * fc * t[:, None]))
    s = math.sqrt(0.5 / 10 ** (snr_db / 10))
    return y + s * (rng.standard_normal(y.shape) + 1j * rng.standard_normal(y.shape))
