"""Selection of the DFT bins inside a frequency band: by frequency axis (:func:`band_bins`, one
error message for an empty selection) or as a contiguous rfft slice (:func:`band_slice`)."""

from __future__ import annotations

import numpy as np

from arrayproc.errors import ConfigError


def band_bins(freqs: np.ndarray, band: list[float] | None, where: str) -> np.ndarray:
    """Indices of ``freqs`` inside ``band`` (all when None); ConfigError naming 'band' if none."""
    if band is None:
        return np.arange(freqs.size)
    idx = np.flatnonzero((freqs >= band[0]) & (freqs <= band[1]))
    if idx.size == 0:
        raise ConfigError(f"{where}: key 'band' {band} holds none of the input's bins "
                          f"({freqs[0]:g}-{freqs[-1]:g} Hz)")
    return idx


def check_nyquist(band: list[float] | tuple[float, float] | None, nyquist: float,
                  where: str) -> None:
    """Refuse a ``band`` whose upper edge lies above the highest frequency of the input
    (``nyquist``: fs/2 for real samples, fc + fs/2 for complex baseband), instead of clipping
    it silently: ConfigError naming the key."""
    if band is not None and nyquist > 0 and band[1] > nyquist * (1 + 1e-12):
        raise ConfigError(f"{where}: key 'band' upper edge {band[1]:g} Hz is above the Nyquist "
                          f"frequency {nyquist:g} Hz of its input")


def band_slice(nfft: int, fs: float, band: tuple[float, float] | None) -> tuple[int, int]:
    """First and one-past-last rfft bin of ``band`` (Hz) for an ``nfft``-point transform.

    Parameters
    ----------
    nfft : int
        Transform length, samples.
    fs : float
        Sample rate, Hz.
    band : (lo, hi) Hz or None
        None: every bin but DC.

    Returns
    -------
    k1, k2 : int
        Bins ``k1 <= k < k2`` with ``lo <= k fs/nfft <= hi``.
    """
    nb = nfft // 2 + 1
    if band is None:
        return 1, nb
    df = fs / nfft
    k1 = max(0, int(np.ceil(band[0] / df - 1e-9)))
    k2 = min(nb, int(np.floor(band[1] / df + 1e-9)) + 1)
    if k2 - k1 < 2:
        raise ValueError(f"band {band} Hz holds fewer than 2 bins at nfft={nfft}, fs={fs}")
    return k1, k2
