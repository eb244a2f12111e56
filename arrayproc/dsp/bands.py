"""Selection of the DFT bins inside a frequency band, with one error message for an empty
selection."""

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
