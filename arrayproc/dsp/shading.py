"""Array shading (spatial tapers) for the conventional beamformer.

Shading trades main-lobe width for sidelobe level (thesis 2.1.1.2 mentions it and does not use
it; the thesis results correspond to ``"none"``). Weights are evaluated at each element's
coordinate along the array's principal axis, normalised so that a uniform line array of N
elements samples the continuous taper at ``x_n = (n - (N-1)/2) / N`` in (-1/2, 1/2), so the
end elements keep a non-zero weight. Non-uniform line arrays get the same continuous taper at
their actual positions; Dolph-Chebyshev has no continuous form and is applied by element rank.
Every result is normalised to mean 1, so the plane-wave gain at the steered direction stays
N_H (thesis eq. 2.14). The cosine and Taylor tapers are closed forms; Dolph-Chebyshev comes
from ``scipy.signal.windows``, imported only when asked for (importing it loads the whole of
``scipy.signal``, about a second of start-up).
"""

from __future__ import annotations

import warnings

import numpy as np

from arrayproc.errors import ConfigError

KINDS = ("none", "hann", "hamming", "taylor", "chebyshev")


def _axis_coordinates(positions: np.ndarray) -> np.ndarray:
    """Element coordinates (n,) along the principal axis, scaled to the (-1/2, 1/2) convention."""
    p = np.asarray(positions, float)
    n = p.shape[0]
    if n < 2:
        return np.zeros(n)
    c = p - p.mean(axis=0)
    _, _, vt = np.linalg.svd(c, full_matrices=False)
    s = c @ vt[0]
    span = s.max() - s.min()
    if span <= 0:
        return np.zeros(n)
    # Uniform line of N elements: ends at ±(N-1)/(2N).
    return (s - 0.5 * (s.max() + s.min())) / span * (n - 1) / n


def taylor_continuous(x: np.ndarray, sidelobe_db: float, nbar: int = 4) -> np.ndarray:
    """Taylor n̄ taper evaluated at x in (-1/2, 1/2) (Taylor 1955; the same coefficients as
    ``scipy.signal.windows.taylor`` without its peak normalisation)."""
    b = 10.0 ** (abs(sidelobe_db) / 20.0)
    a = np.arccosh(b) / np.pi
    s2 = nbar**2 / (a**2 + (nbar - 0.5) ** 2)
    ma = np.arange(1, nbar)
    fm = np.empty(nbar - 1)
    signs = np.empty_like(ma)
    signs[::2] = 1
    signs[1::2] = -1
    m2 = ma**2
    for mi in range(ma.size):
        num = np.prod(1 - m2[mi] / s2 / (a**2 + (ma - 0.5) ** 2))
        den = 2 * np.prod(1 - m2[mi] / m2[:mi]) * np.prod(1 - m2[mi] / m2[mi + 1:])
        fm[mi] = signs[mi] * num / den
    w = np.ones_like(np.asarray(x, float))
    for mi, m in enumerate(ma):
        w = w + 2 * fm[mi] * np.cos(2 * np.pi * m * np.asarray(x, float))
    return w


def shading_weights(kind: str, positions: np.ndarray, sidelobe_db: float = 30.0,
                    nbar: int = 4) -> np.ndarray:
    """Shading weights (n,) for elements at ``positions`` (n, 3) m, mean 1.

    ``kind`` is one of :data:`KINDS`; ``sidelobe_db`` (dB below the main lobe, > 0) is used by
    ``taylor`` and ``chebyshev``.
    """
    n = np.asarray(positions).shape[0]
    if kind == "none" or n < 2:
        w = np.ones(n)
    elif kind in ("hann", "hamming"):
        x = _axis_coordinates(positions)
        a0 = 0.5 if kind == "hann" else 0.54
        w = a0 + (1 - a0) * np.cos(2 * np.pi * x)
    elif kind == "taylor":
        w = taylor_continuous(_axis_coordinates(positions), sidelobe_db, nbar)
    elif kind == "chebyshev":
        order = np.argsort(_axis_coordinates(positions), kind="stable")
        w = np.empty(n)
        from scipy.signal.windows import chebwin  # imports all of scipy.signal: only here
        with warnings.catch_warnings():  # scipy warns about spectral-analysis use below 45 dB
            warnings.simplefilter("ignore", UserWarning)
            w[order] = chebwin(n, abs(sidelobe_db))
    else:
        raise ConfigError(f"shading: unknown kind {kind!r} (known: {', '.join(KINDS)})")
    return w / w.mean()
