"""Source level and received sound pressure level (SPL paper section 3).

Levels in dB re 1 µPa; source level in dB re 1 µPa @ 1 m; TL in dB re 1 m.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

__all__ = ["SourceLevelModel", "ROSS_SURFACE_SHIP", "received_level", "simulate_levels"]


@dataclass(frozen=True)
class SourceLevelModel:
    """SL(v) = sl0 + slope · log10(v / v_ref) (SPL paper eq. (12); Ross 1987 ch. 8.6).

    ``v`` is the target speed, sqrt(vx² + vy²) in m/s.
    """

    sl0_db: float = 170.0
    slope_db: float = 53.0
    v_ref: float = 5.14       # m/s (10 kn)

    def __call__(self, speed: np.ndarray | float) -> np.ndarray:
        v = np.maximum(np.asarray(speed, dtype=float), 1e-6)
        return self.sl0_db + self.slope_db * np.log10(v / self.v_ref)

    def as_array(self) -> np.ndarray:
        """[sl0, slope, v_ref] for the numba kernels."""
        return np.array([self.sl0_db, self.slope_db, self.v_ref])


ROSS_SURFACE_SHIP = SourceLevelModel()


def received_level(target_state: np.ndarray, observer_pos: np.ndarray,
                   tl: Callable[[np.ndarray], np.ndarray],
                   sl: SourceLevelModel = ROSS_SURFACE_SHIP) -> np.ndarray:
    """Noise-free received level h_l = SL(v) − TL(r) (SPL paper eq. (16)), dB re 1 µPa.

    ``target_state`` (..., 4) [x, y, vx, vy]; ``observer_pos`` (..., 2); ``tl(range_m)`` gives TL
    in dB at the horizontal range (depths fixed by the caller).
    """
    x = np.asarray(target_state, dtype=float)
    d = x[..., :2] - np.asarray(observer_pos, dtype=float)
    r = np.hypot(d[..., 0], d[..., 1])
    v = np.hypot(x[..., 2], x[..., 3])
    return sl(v) - tl(r)


def simulate_levels(target_state: np.ndarray, observer_pos: np.ndarray,
                    tl: Callable[[np.ndarray], np.ndarray], sigma_db: float,
                    rng: np.random.Generator,
                    sl: SourceLevelModel = ROSS_SURFACE_SHIP) -> np.ndarray:
    """Measured levels l_k = h_l + υ_k, υ_k ~ N(0, σ_l²) (SPL paper eq. (15))."""
    h = received_level(target_state, observer_pos, tl, sl)
    return h + sigma_db * rng.standard_normal(h.shape)
