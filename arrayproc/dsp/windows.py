"""Time tapers for DFT frames, normalised to coherent gain 1 (thesis 2.1.2: a bin-centred tone
keeps its DFT amplitude whatever the taper).

The tapers the stages offer are generalised cosine windows, evaluated here in closed form
with the same arithmetic as ``scipy.signal.get_window`` (a symmetric window of ``nfft + 1``
points on ``linspace(-pi, pi)``, the last point dropped): importing ``scipy.signal`` for them
cost 0.8-1.6 s of every command's start-up (docs/performance/startup.md). Any other window
name is passed to ``scipy.signal.get_window``, imported then.
"""

from __future__ import annotations

import numpy as np

#: cosine-sum coefficients a_k of w(x) = sum_k a_k cos(k x), x in [-pi, pi] (Harris 1978)
COSINE_SUMS = {
    "hann": (0.5, 0.5),
    "hamming": (0.54, 1 - 0.54),  # as scipy writes it (1 - 0.54 is not 0.46 in binary)
    "blackman": (0.42, 0.50, 0.08),
    "blackmanharris": (0.35875, 0.48829, 0.14128, 0.01168),
}


def periodic_cosine_sum(coefficients: tuple[float, ...], nfft: int) -> np.ndarray:
    """Periodic (DFT-even) cosine-sum window of length ``nfft``, peak 1 at the centre.

    ``w[n] = sum_k a_k cos(k (2 pi n / nfft - pi))`` for n = 0 .. nfft - 1 (Harris 1978,
    eq. 30 with the origin at the centre).
    """
    x = np.linspace(-np.pi, np.pi, nfft + 1)
    w = np.zeros(nfft + 1)
    for k, a in enumerate(coefficients):
        w += a * np.cos(k * x)
    return w[:-1]


def time_taper(name: str, nfft: int) -> np.ndarray:
    """Periodic time taper of length ``nfft`` normalised to mean 1 (coherent gain 1)."""
    if name == "none":
        return np.ones(nfft)
    if name in COSINE_SUMS:
        w = periodic_cosine_sum(COSINE_SUMS[name], nfft)
    else:  # any other scipy window name: rare, so scipy.signal is imported only here
        from scipy.signal import get_window
        w = get_window(name, nfft, fftbins=True)
    return w / w.mean()
