"""Warnings for beamformer set-ups that run but give wrong beams: a line array that does not lie
along body x under cone-angle beams, and a band above the array's spatial-aliasing limit.

Both are checked when a stage sees its first block (the geometry and the band's bins are known
then) and go through Python's :mod:`warnings`, which the command line prints as one
``arrayproc: warning: …`` line.

Spatial aliasing: a uniform line of spacing d has grating lobes inside visible space above
f = c / (2 d) (steering to end-fire; thesis ch. 2, the half-wavelength rule). For cone-angle
beams d is the typical spacing of the elements along body x (the uniform spacing of a line
array); for 3-D steering it is the median distance of an element to its nearest neighbour.
"""

from __future__ import annotations

import warnings

import numpy as np

#: Rows of the pairwise-distance matrix computed at a time (bounded memory on big arrays).
_CHUNK = 256


def typical_spacing(positions: np.ndarray, mode: str = "cone") -> float:
    """Typical element spacing d (m): along body x for ``mode = "cone"`` (the median gap
    between successive distinct x positions), else the median nearest-neighbour distance.

    Parameters
    ----------
    positions : (n, 3) array
        Element positions, body frame, m.
    mode : str
        ``"cone"`` or ``"3d"``.

    Returns
    -------
    float
        d in m; 0 when the elements do not spread (fewer than 2 distinct positions).
    """
    p = np.asarray(positions, float)
    if mode == "cone":
        gaps = np.diff(np.sort(p[:, 0]))
        gaps = gaps[gaps > 1e-9]
        return float(np.median(gaps)) if gaps.size else 0.0
    nearest = []
    for a in range(0, p.shape[0], _CHUNK):
        d = np.linalg.norm(p[a:a + _CHUNK, None, :] - p[None, :, :], axis=-1)
        d[d <= 1e-9] = np.inf
        nearest.append(d.min(axis=1))
    nn = np.concatenate(nearest) if nearest else np.zeros(0)
    nn = nn[np.isfinite(nn)]
    return float(np.median(nn)) if nn.size else 0.0


def warn_cone_geometry(where: str, positions: np.ndarray) -> None:
    """Warn when cone-angle beams are asked of elements that spread across body x more than
    along it (a line laid along y or z): the cone-angle beamformer uses only the x
    coordinates, so such an array gives a flat beam pattern and no bearings."""
    p = np.asarray(positions, float)
    if p.shape[0] < 2:
        return
    along = float(np.ptp(p[:, 0]))
    across = float(max(np.ptp(p[:, 1]), np.ptp(p[:, 2])))
    if across > along:
        axis = "y" if np.ptp(p[:, 1]) >= np.ptp(p[:, 2]) else "z"
        warnings.warn(f"{where}: cone-angle beams assume a line array along body x, but the "
                      f"elements spread {across:.3g} m along {axis} and {along:.3g} m along x: "
                      "the beams will be nearly flat (lay the line along x in the geometry, or "
                      "steer in 3-D with beams = {bearings, elevations})", stacklevel=3)


def warn_spatial_aliasing(where: str, positions: np.ndarray, f_max: float, c: float,
                          mode: str = "cone") -> None:
    """Warn when the band reaches above the spatial-aliasing limit f = c / (2 d) of the array
    (grating lobes: beams at other angles see the same wave).

    Parameters
    ----------
    where : str
        Stage, for the message.
    positions : (n, 3) array
        Element positions, m.
    f_max : float
        Highest frequency beamformed, Hz.
    c : float
        Sound speed, m/s.
    mode : str
        ``"cone"`` or ``"3d"`` (see :func:`typical_spacing`).
    """
    d = typical_spacing(positions, mode)
    if not (d > 0 and c > 0):
        return
    limit = c / (2.0 * d)
    if f_max > limit * (1 + 1e-9):
        warnings.warn(f"{where}: key 'band' reaches {f_max:g} Hz, above the array's spatial-"
                      f"aliasing limit c/(2d) = {limit:g} Hz (d = {d:.4g} m, c = {c:g} m/s): "
                      "beams above it have grating lobes (ambiguous bearings)", stacklevel=3)
