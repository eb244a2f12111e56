"""Beam fans: the ``beams`` table of a chain stage (cone angles of a line array, or bearings and
elevations for a volumetric array) turned into beam axes and body-frame unit directions
(docs/architecture.md: body x forward, y starboard, z down; cone 0 deg forward end-fire)."""

from __future__ import annotations

import numpy as np

from arrayproc.errors import ConfigError


def beam_count(v: object) -> int:
    """A beam count: a TOML integer (not a fraction, a string or a boolean); TypeError
    otherwise."""
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
        raise TypeError(f"count must be an integer, got {v!r}")
    return int(v)


def beam_directions(beams: dict) -> tuple[np.ndarray, np.ndarray, str]:
    """Beam axis and unit direction vectors from a ``beams`` table.

    Returns ``(axis, dirs, mode)``: ``axis`` cone angles (B,) deg or (B, 2) [bearing,
    elevation] deg; ``dirs`` (B, 3) body-frame unit vectors (for cone beams only the x
    component, cos θ, is used); ``mode`` is ``"cone"`` or ``"3d"``.
    """
    keys = set(beams)
    if keys <= {"start", "stop", "count", "spacing"} and {"start", "stop", "count"} <= keys:
        try:
            a, b, n = float(beams["start"]), float(beams["stop"]), beam_count(beams["count"])
        except (TypeError, ValueError):
            raise ConfigError("key 'beams': start, stop must be numbers and count an "
                              "integer") from None
        if n < 1 or not (0.0 <= a <= 180.0 and 0.0 <= b <= 180.0):
            raise ConfigError("key 'beams': cone angles must lie in [0, 180] deg and count >= 1")
        spacing = beams.get("spacing", "angle")
        if spacing == "angle":
            cone = np.linspace(a, b, n)
        elif spacing == "cos":
            cone = np.rad2deg(np.arccos(np.linspace(np.cos(np.deg2rad(a)),
                                                    np.cos(np.deg2rad(b)), n)))
        else:
            raise ConfigError("key 'beams': spacing must be 'angle' or 'cos'")
        dirs = np.zeros((n, 3))
        dirs[:, 0] = np.cos(np.deg2rad(cone))
        return cone, dirs, "cone"
    if "bearings" in keys and keys <= {"bearings", "elevations"}:
        try:
            brg = np.asarray(beams["bearings"], float).reshape(-1)
            elv = np.asarray(beams.get("elevations", [0.0]), float).reshape(-1)
        except (TypeError, ValueError):
            raise ConfigError("key 'beams': bearings and elevations must be lists of "
                              "numbers") from None
        if brg.size == 0 or elv.size == 0 or np.any(np.abs(elv) > 90):
            raise ConfigError("key 'beams': need at least one bearing and elevations in "
                              "[-90, 90] deg")
        e, b = np.meshgrid(np.deg2rad(elv), np.deg2rad(brg), indexing="ij")
        e, b = e.ravel(), b.ravel()
        dirs = np.stack([np.cos(e) * np.cos(b), np.cos(e) * np.sin(b), -np.sin(e)], -1)
        axis = np.stack([np.rad2deg(b), np.rad2deg(e)], -1)
        return axis, dirs, "3d"
    raise ConfigError("key 'beams': expected {start, stop, count} (cone angles, deg) or "
                      "{bearings = [...], elevations = [...]} (deg)")


def cone_axis(beams: dict) -> np.ndarray:
    """Cone angles (deg) of a ``{start, stop, count}`` beams table."""
    try:
        a, b, n = float(beams["start"]), float(beams["stop"]), beam_count(beams["count"])
    except (KeyError, TypeError, ValueError):
        raise ConfigError("key 'beams': expected {start, stop, count} cone angles (deg)") from None
    if n < 1 or not (0 <= a <= 180 and 0 <= b <= 180) or set(beams) - {"start", "stop", "count"}:
        raise ConfigError("key 'beams': expected {start, stop, count} with angles in [0, 180]")
    return np.linspace(a, b, n)
