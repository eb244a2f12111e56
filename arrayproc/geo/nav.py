"""Navigation track of the array reference point, interpolated at block times."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Nav:
    """Array reference-point track (``/nav``, docs/formats.md).

    ``time`` (n,) s strictly increasing; ``position`` (n, 2) m (x east, y north); ``heading``
    (n,) deg true; ``depth`` (n,) m or None.
    """

    time: np.ndarray
    position: np.ndarray
    heading: np.ndarray
    depth: np.ndarray | None = None

    @classmethod
    def static(cls, position=(0.0, 0.0), heading: float = 0.0) -> Nav:
        """A static array: fixed position and heading."""
        return cls(np.array([0.0]), np.asarray(position, float).reshape(1, 2),
                   np.array([float(heading)]), None)

    def __post_init__(self) -> None:
        # Heading unwrapped once so that interpolation is continuous across 359°/0°.
        object.__setattr__(self, "_heading_unwrapped",
                           np.rad2deg(np.unwrap(np.deg2rad(self.heading))))

    def at(self, t: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Position (n, 2), heading (n,) deg in [0, 360), depth (n,) and speed (n,) at times t.

        Position and depth interpolate linearly, heading on the circle (shortest way between
        fixes); outside the track the end values are held.
        """
        t = np.atleast_1d(np.asarray(t, dtype=float))
        if self.time.size == 1:
            pos = np.repeat(self.position, t.size, axis=0)
            hd = np.full(t.size, float(self.heading[0]) % 360.0)
            dp = np.full(t.size, 0.0 if self.depth is None else float(self.depth[0]))
            return pos, hd, dp, np.zeros(t.size)
        pos = np.stack([np.interp(t, self.time, self.position[:, i]) for i in range(2)], -1)
        hd = np.mod(np.interp(t, self.time, self._heading_unwrapped), 360.0)
        dp = (np.zeros(t.size) if self.depth is None else np.interp(t, self.time, self.depth))
        v = np.diff(self.position, axis=0) / np.diff(self.time)[:, None]
        seg = np.clip(np.searchsorted(self.time, t, side="right") - 1, 0, len(v) - 1)
        spd = np.hypot(v[seg, 0], v[seg, 1])
        return pos, hd, dp, spd

