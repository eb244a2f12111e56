"""Angle arithmetic: the one home of every angle wrap in arrayproc.

Conventions (docs/architecture.md): a *true bearing* or course is clockwise from north,
``atan2(dx, dy)`` with x east and y north; degrees at public interfaces, radians inside.
``wrap_pi_scalar`` is the scalar form for numba kernels: a kernel module compiles it with
``numba.njit(wrap_pi_scalar)`` so that compiled and numpy code wrap with the same arithmetic,
``(a + π) mod 2π − π`` (floor modulo, result in [−π, π)).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["wrap_pi", "wrap_pi_scalar", "wrap_180", "wrap_2pi", "true_bearing",
           "interp_angle_deg"]

TWO_PI = 2.0 * math.pi


def wrap_pi(a: np.ndarray | float) -> np.ndarray:
    """Wrap angles to [−π, π).

    Parameters
    ----------
    a : array_like
        Angles, rad.

    Returns
    -------
    ndarray
        ``(a + π) mod 2π − π``, rad.
    """
    return np.mod(np.asarray(a) + np.pi, 2.0 * np.pi) - np.pi


def wrap_pi_scalar(a: float) -> float:
    """Scalar :func:`wrap_pi` (rad → rad in [−π, π)) written for numba kernels."""
    return (a + math.pi) % TWO_PI - math.pi


def wrap_180(a: np.ndarray | float) -> np.ndarray:
    """Wrap angles to [−180, 180).

    Parameters
    ----------
    a : array_like
        Angles, deg.

    Returns
    -------
    ndarray
        ``(a + 180) mod 360 − 180``, deg.
    """
    return np.mod(np.asarray(a) + 180.0, 360.0) - 180.0


def wrap_2pi(a: np.ndarray | float) -> np.ndarray:
    """Wrap angles to [0, 2π).

    Parameters
    ----------
    a : array_like
        Angles, rad.

    Returns
    -------
    ndarray
        ``a mod 2π``, rad.
    """
    return np.mod(a, 2.0 * np.pi)


def true_bearing(dx: np.ndarray | float, dy: np.ndarray | float) -> np.ndarray:
    """True bearing of the vector (dx east, dy north): ``atan2(dx, dy)`` in [0, 2π).

    Parameters
    ----------
    dx, dy : array_like
        East and north components, m (any common unit).

    Returns
    -------
    ndarray
        Bearing clockwise from north, rad in [0, 2π).
    """
    return np.mod(np.arctan2(dx, dy), 2.0 * np.pi)


def interp_angle_deg(t: np.ndarray, tp: np.ndarray, ap_deg: np.ndarray) -> np.ndarray:
    """Interpolate angles on the circle: linear in the unwrapped angle.

    Parameters
    ----------
    t : array_like
        Times at which to interpolate (any unit shared with ``tp``).
    tp : array_like
        Increasing sample times.
    ap_deg : array_like
        Angles at ``tp``, deg.

    Returns
    -------
    ndarray
        Angles at ``t``, deg in [0, 360).
    """
    unwrapped = np.rad2deg(np.unwrap(np.deg2rad(np.asarray(ap_deg, dtype=float))))
    return np.mod(np.interp(t, tp, unwrapped), 360.0)
