"""Track initialisation from the first bearing (Ristic, Arulampalam & Gordon 2003, ch. 6) with
the priors of the L-R paper, section V."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from arrayproc.geo.kinematics import KNOT
from arrayproc.track import _kernels as kc


@dataclass(frozen=True)
class TrackPrior:
    """Prior of the first-bearing initialisation; public units m, m/s, degrees.

    Defaults: L-R paper section V — range 5 km ± 2 km, speed 4 kn ± 2 kn, bearing σ 1.5°,
    course σ π/√12 rad (≈ 51.96°) about the bearing plus 180° (target heading towards the
    observer). ``sigma_turn_deg_s``: prior σ of the CT turn rate (not stated in the paper;
    default 3°/min).
    """

    range_m: float = 5000.0
    sigma_range_m: float = 2000.0
    speed_mps: float = 4.0 * KNOT
    sigma_speed_mps: float = 2.0 * KNOT
    sigma_bearing_deg: float = 1.5
    sigma_course_deg: float = math.degrees(math.pi / math.sqrt(12.0))
    sigma_turn_deg_s: float = 3.0 / 60.0

    def as_array(self) -> np.ndarray:
        """[r̄, σr, s̄, σs, σθ, σc, σψ] in SI/radians, the kernel's ``prior`` vector."""
        return np.array([self.range_m, self.sigma_range_m, self.speed_mps, self.sigma_speed_mps,
                         math.radians(self.sigma_bearing_deg),
                         math.radians(self.sigma_course_deg),
                         math.radians(self.sigma_turn_deg_s)])


def initial_state(bearing_rad: float, own_state: np.ndarray, prior: TrackPrior,
                  dim: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """Relative state and covariance from one bearing (Ristic et al. 2003, ch. 6):
    x = r̄ [sin θ, cos θ], ẋ = s̄ [sin c̄, cos c̄] − ẋ^o with c̄ = θ + π, covariances by
    linearising the polar priors.

    Parameters
    ----------
    bearing_rad : float
        First bearing θ, rad.
    own_state : (4,) array_like
        Observer [x, y, ẋ, ẏ] (m, m/s).
    prior : TrackPrior
    dim : int
        4 (CV) or 5 (CT, turn rate 0 ± σψ).

    Returns
    -------
    x : (dim,) ndarray
    P : (dim, dim) ndarray
    """
    x = np.empty(dim)
    P = np.empty((dim, dim))
    p = prior.as_array()
    kc.init_from_bearing(float(bearing_rad), np.asarray(own_state, float), p[0], p[1], p[2],
                         p[3], p[4], p[5], p[6], x, P, p[0], p[2], 0.0)
    return x, P


def init_from_bearing(bearing_deg: float, own_state: np.ndarray, prior: TrackPrior,
                      dim: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """:func:`initial_state` with the bearing in degrees."""
    return initial_state(math.radians(bearing_deg), own_state, prior, dim)
