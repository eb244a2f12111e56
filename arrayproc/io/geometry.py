"""Array geometry: element positions in the body frame and their pose in the world frame.

Body frame (docs/architecture.md): x forward along the array heading, y starboard, z down, origin at
the array reference point. World frame: x east, y north, z down.
"""

from __future__ import annotations

import csv
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from arrayproc.errors import FormatError


def line_array(n: int, spacing: float) -> np.ndarray:
    """Positions (n, 3) of a uniform line array along the body x axis, centred on the origin.

    Element 0 is the most forward one (x = (n-1)/2 · spacing); the reference point is the
    array's acoustic centre, so phase references sit mid-array.
    """
    if n < 1 or not spacing > 0:
        raise FormatError(f"line array needs n >= 1 and spacing > 0 (got {n}, {spacing})")
    pos = np.zeros((n, 3))
    pos[:, 0] = ((n - 1) / 2.0 - np.arange(n)) * spacing
    return pos


def twin_line_array(n: int, spacing: float, separation: float) -> np.ndarray:
    """Positions (2n, 3) of a twin line array: two uniform lines of ``n`` stations along body x,
    ``separation`` m apart across (y = ∓separation/2, port then starboard at each station;
    channels station by station from the forward end). The cross-axis offset is what resolves
    port from starboard (thesis 2.2.4.1)."""
    if not separation > 0:
        raise FormatError(f"twin line array needs separation > 0 (got {separation})")
    line = line_array(n, spacing)
    pos = np.repeat(line, 2, axis=0)
    pos[0::2, 1] = -separation / 2.0
    pos[1::2, 1] = separation / 2.0
    return pos


#: Angles of a triplet's hydrophones around the array axis, deg from starboard (+y) towards
#: down (+z): one on top, two below on either side (an equilateral triangle).
TRIPLET_ANGLES_DEG = (-90.0, 30.0, 150.0)


def triplet_array(n: int, spacing: float, radius: float) -> np.ndarray:
    """Positions (3n, 3) of a triplet array (Groen et al. 2005): ``n`` stations along body x,
    each with three hydrophones on a circle of ``radius`` m around the axis at
    :data:`TRIPLET_ANGLES_DEG`; channels station by station from the forward end. The
    cross-axis aperture (y extent) is √3·radius."""
    if not radius > 0:
        raise FormatError(f"triplet array needs radius > 0 (got {radius})")
    line = line_array(n, spacing)
    pos = np.repeat(line, 3, axis=0)
    ang = np.deg2rad(np.tile(TRIPLET_ANGLES_DEG, n))
    pos[:, 1] = radius * np.cos(ang)
    pos[:, 2] = radius * np.sin(ang)
    return pos


def read_geometry_csv(path: str | Path) -> np.ndarray:
    """Element positions (n, 3) in m from a CSV with a header holding columns ``x, y, z``.

    Other columns are ignored; one row per element, in channel order.
    """
    path = Path(path)
    try:
        with open(path, newline="") as f:
            rows = list(csv.DictReader(f))
    except FileNotFoundError:
        raise FormatError(f"{path}: no such geometry file") from None
    except (OSError, UnicodeDecodeError, csv.Error) as e:
        raise FormatError(f"{path}: cannot read geometry CSV ({e})") from None
    if not rows:
        raise FormatError(f"{path}: geometry CSV has no rows")
    keys = {k.strip().lower(): k for k in rows[0] if k is not None}
    missing = [c for c in "xyz" if c not in keys]
    if missing:
        raise FormatError(f"{path}: geometry CSV lacks column(s) {', '.join(missing)}")
    try:
        pos = np.array([[float(r[keys[c]]) for c in "xyz"] for r in rows])
    except (TypeError, ValueError) as e:
        raise FormatError(f"{path}: geometry CSV has a non-numeric position ({e})") from None
    if not np.all(np.isfinite(pos)):
        raise FormatError(f"{path}: geometry CSV has a non-finite position")
    return pos


def read_geometry_xml(path: str | Path) -> np.ndarray:
    """Element positions (n, 3) in m from acoular's XML geometry (``<MicArray><pos x= y= z=/>``)."""
    path = Path(path)
    try:
        root = ET.parse(path).getroot()
    except FileNotFoundError:
        raise FormatError(f"{path}: no such geometry file") from None
    except (OSError, ET.ParseError) as e:
        raise FormatError(f"{path}: cannot parse geometry XML ({e})") from None
    try:
        pos = np.array([[float(p.attrib[c]) for c in "xyz"] for p in root.iter("pos")])
    except (KeyError, ValueError) as e:
        raise FormatError(f"{path}: a <pos> element lacks a numeric x, y or z ({e})") from None
    if pos.size == 0:
        raise FormatError(f"{path}: geometry XML has no <pos> elements")
    if not np.all(np.isfinite(pos)):
        raise FormatError(f"{path}: geometry XML has a non-finite position (NaN or Inf)")
    return pos


def read_geometry(path: str | Path) -> np.ndarray:
    """Element positions from a CSV or acoular XML file, chosen by the file's extension."""
    if Path(path).suffix.lower() == ".xml":
        return read_geometry_xml(path)
    return read_geometry_csv(path)


def body_to_world(positions: np.ndarray, reference: np.ndarray, heading_deg: float,
                  depth: float = 0.0) -> np.ndarray:
    """Element positions (n, 3) in the world frame (x east, y north, z down), m.

    The body x axis (forward) points along the true heading, the body y axis (starboard) 90°
    clockwise from it: world = reference + x·(sin h, cos h) + y·(cos h, −sin h), z + depth.
    """
    h = np.deg2rad(heading_deg)
    s, c = np.sin(h), np.cos(h)
    out = np.empty_like(positions, dtype=float)
    out[:, 0] = reference[0] + positions[:, 0] * s + positions[:, 1] * c
    out[:, 1] = reference[1] + positions[:, 0] * c - positions[:, 1] * s
    out[:, 2] = positions[:, 2] + depth
    return out


def aperture(positions: np.ndarray, chunk_pairs: int = 1 << 20) -> float:
    """Largest distance (m) between two elements.

    Exact, in row chunks of about ``chunk_pairs`` pairs, so memory stays O(n) however many
    elements there are (8,000 elements: about 25 MB, not the 1.5 GB of a full n × n × 3 array).
    """
    pos = np.asarray(positions, dtype=float)
    n = len(pos)
    if n < 2:
        return 0.0
    rows = max(1, chunk_pairs // n)
    best = 0.0
    for i in range(0, n, rows):
        d = pos[i:i + rows, None, :] - pos[None, :, :]
        best = max(best, float(np.einsum("ijk,ijk->ij", d, d).max()))
    return float(np.sqrt(best))


def geometry_kind(positions: np.ndarray, tol: float = 1e-9) -> str:
    """``"line"`` (uniform or not, on one straight line), ``"planar"`` or ``"volumetric"``."""
    if len(positions) < 3:
        return "line"
    centred = positions - positions.mean(axis=0)
    s = np.linalg.svd(centred, compute_uv=False)
    scale = max(s[0], tol)
    rank = int(np.sum(s > 1e-6 * scale))
    return {1: "line", 2: "planar"}.get(rank, "volumetric")
