"""Closed-form transmission loss (dB re 1 m): spherical, cylindrical, and spherical spreading to
a transition range followed by cylindrical spreading, each optionally with volume absorption.

    spherical          TL = 20 log10 r + α r
    cylindrical        TL = 10 log10 r + α r
    sph-to-cyl         TL = 20 log10 r                      + α r   (r ≤ r_t)
                       TL = 20 log10 r_t + 10 log10 (r/r_t) + α r   (r > r_t)

(Urick 1983, ch. 5; r in m, α in dB/m.) Ranges below 1 m are clamped to 1 m (TL = 0 there).
The absorption coefficient ``thorp_db_per_km`` is Thorp's formula (Urick 1983 eq. 5.3).
The depth arguments exist so that these forms share the signature of
:class:`~arrayproc.acoustics.tl.table.TLTable` (range, source depth, receiver depth).
"""

from __future__ import annotations

import numpy as np

__all__ = ["thorp_db_per_km", "spherical", "cylindrical", "spherical_to_cylindrical"]


def thorp_db_per_km(freq_hz: float | np.ndarray) -> np.ndarray:
    """Thorp's sea-water absorption (dB/km) at frequency ``freq_hz`` (Hz)."""
    f2 = (np.asarray(freq_hz, dtype=float) / 1000.0) ** 2
    return 0.11 * f2 / (1 + f2) + 44.0 * f2 / (4100.0 + f2) + 2.75e-4 * f2 + 0.003


def _r(range_m) -> np.ndarray:
    return np.maximum(np.asarray(range_m, dtype=float), 1.0)


def spherical(range_m, src_depth=None, rcv_depth=None, alpha_db_per_m: float = 0.0) -> np.ndarray:
    """Spherical spreading ``20 log10 r + α r`` (dB)."""
    r = _r(range_m)
    return 20.0 * np.log10(r) + alpha_db_per_m * r


def cylindrical(range_m, src_depth=None, rcv_depth=None,
                alpha_db_per_m: float = 0.0) -> np.ndarray:
    """Cylindrical spreading ``10 log10 r + α r`` (dB)."""
    r = _r(range_m)
    return 10.0 * np.log10(r) + alpha_db_per_m * r


def spherical_to_cylindrical(range_m, src_depth=None, rcv_depth=None,
                             transition_m: float = 1000.0,
                             alpha_db_per_m: float = 0.0) -> np.ndarray:
    """Spherical to ``transition_m`` (e.g. the water depth), cylindrical beyond, plus α r (dB)."""
    r = _r(range_m)
    rt = float(transition_m)
    tl = np.where(r <= rt, 20.0 * np.log10(r), 20.0 * np.log10(rt) + 10.0 * np.log10(r / rt))
    return tl + alpha_db_per_m * r
