"""Time tapers for DFT frames, normalised to coherent gain 1 (thesis 2.1.2: a bin-centred tone
keeps its DFT amplitude whatever the taper)."""

from __future__ import annotations

import numpy as np
from scipy.signal import get_window


def time_taper(name: str, nfft: int) -> np.ndarray:
    """Periodic time taper of length ``nfft`` normalised to mean 1 (coherent gain 1)."""
    if name == "none":
        return np.ones(nfft)
    w = get_window(name, nfft, fftbins=True)
    return w / w.mean()
