"""Where two bearing rays from known points cross (the cross-fix of two arrays)."""

from __future__ import annotations

import numpy as np

__all__ = ["ray_intersection"]


def ray_intersection(a: np.ndarray, ba: float, b: np.ndarray, bb: float) -> np.ndarray | None:
    """Intersection of the ray from ``a`` at bearing ``ba`` with the ray from ``b`` at ``bb``.

    Parameters
    ----------
    a, b : (2,) array_like
        Ray origins [x east, y north] (m).
    ba, bb : float
        Bearings (rad, clockwise from north).

    Returns
    -------
    (2,) ndarray or None
        ``a + r_a u(ba)`` with ``a + r_a u(ba) = b + r_b u(bb)``, ``u(β) = [sin β, cos β]``;
        None when the rays are parallel (|det| < 1e-6) or meet behind either origin.

    Examples
    --------
    >>> import numpy as np
    >>> ray_intersection(np.zeros(2), np.pi / 4, np.array([2.0, 0.0]), -np.pi / 4)
    array([1., 1.])
    """
    a = np.asarray(a, float)
    b = np.asarray(b, float)
    ua = np.array([np.sin(ba), np.cos(ba)])
    ub = np.array([np.sin(bb), np.cos(bb)])
    m = np.column_stack([ua, -ub])
    if abs(np.linalg.det(m)) < 1e-6:
        return None
    ra, rb = np.linalg.solve(m, b - a)
    if ra <= 0 or rb <= 0:
        return None
    return a + ra * ua
