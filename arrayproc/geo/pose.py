"""The array's pose at one instant (position, heading, depth, speed, element positions)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Pose:
    """The array's pose at one instant.

    Attributes
    ----------
    position : (2,) ndarray
        Array reference point, x east / y north, m.
    heading : float
        Array heading, deg true (direction of the body x axis).
    depth : float
        Reference-point depth, m (0 when unknown).
    speed : float
        Speed over ground of the reference point, m/s (from the navigation track).
    elements : (n, 3) ndarray
        Element positions in the world frame (x east, y north, z down), m.
    """

    position: np.ndarray
    heading: float
    depth: float
    speed: float
    elements: np.ndarray
