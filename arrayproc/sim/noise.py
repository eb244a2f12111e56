"""Ambient noise: Gaussian, independent on every element, flat or coloured.

Flat: one-sided spectral level L dB re 1 µPa²/Hz over 0 … fs/2 (white, variance
1e-12 · 10^(L/10) · fs/2 Pa²). Coloured: a ``spectrum`` of (f, L) points interpolated linearly
in dB against log f (held beyond the first/last point), realised by a linear-phase FIR.
"""

from __future__ import annotations

import numpy as np

from arrayproc.sim.scenario import NoiseSpec
from arrayproc.sim.signals import ShapedNoise, level_to_psd

KEY_NOISE = 21


def noise_psd(spec: NoiseSpec):
    """PSD function f (Hz) → Pa²/Hz of a noise spec."""
    if spec.spectrum is None:
        p = float(level_to_psd(spec.level_db))
        return lambda f: np.full(np.shape(f), p)
    lf = np.log(spec.spectrum[:, 0])
    lv = spec.spectrum[:, 1]

    def psd(f: np.ndarray) -> np.ndarray:
        f = np.maximum(np.asarray(f, dtype=float), spec.spectrum[0, 0] * 1e-3)
        return level_to_psd(np.interp(np.log(f), lf, lv))

    return psd


def ambient_noise(spec: NoiseSpec, fs: float, n_channels: int, seed: int) -> ShapedNoise:
    """A chunk-independent ambient-noise generator (``.block(k0, k1)`` → (n, ch) float32)."""
    if spec.spectrum is None:
        return ShapedNoise(fs, seed, (KEY_NOISE,), n_channels, psd=None,
                           white_psd=float(level_to_psd(spec.level_db)), dtype=np.float32)
    p_ref = float(level_to_psd(spec.spectrum[:, 1].max()))
    return ShapedNoise(fs, seed, (KEY_NOISE,), n_channels, psd=noise_psd(spec), white_psd=p_ref,
                       dtype=np.float32)
