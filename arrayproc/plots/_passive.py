"""Helpers shared by the passive plots: product lookup, colour scale, truth access."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from arrayproc.errors import ArrayprocError, FormatError


def find_group(path: str, kind: str, prod: Any = None) -> tuple[dict[str, Any], dict[str, Any]]:
    """The first products group of ``kind`` and the root attributes (of ``prod``, the file
    as read, when given)."""
    from arrayproc.io.products import read_products
    prod = read_products(path) if prod is None else prod
    for g in prod.groups(kind).values():
        if "time" not in g:
            raise ArrayprocError(f"{path}: {kind} product is empty (no rows)")
        return g, prod.root
    raise ArrayprocError(f"{path}: no {kind} product (kinds: "
                         f"{', '.join(sorted(set(prod.kinds())))})")


def robust_top(x: np.ndarray) -> float:
    """Top of the colour scale: the 99.9th percentile of the finite values (dB)."""
    v = np.asarray(x, float)
    v = v[np.isfinite(v)]
    return float(np.percentile(v, 99.9)) if v.size else 0.0


def open_truth_recording(root: dict[str, Any]):
    """The recording named by the products' ``source`` attribute, if it exists and has
    ``/truth/sources``; otherwise None."""
    src = root.get("source", "")
    src = src.decode() if isinstance(src, bytes) else str(src)
    if not src or not Path(src).is_file():
        return None
    from arrayproc.io.recording import Recording
    try:
        rec = Recording(src)
    except FormatError:
        return None
    if not rec.has("truth/sources"):
        rec.close()
        return None
    return rec


def true_bearings(rec, t: np.ndarray) -> dict[str, np.ndarray]:
    """True bearing (deg, [0, 360), clockwise from north) from the array's reference point to
    each truth source at times ``t`` (straight lines at the reception time: for display)."""
    from arrayproc.geo.angles import true_bearing
    from arrayproc.io.truth import sources
    pa = rec.nav.at(t)[0]
    out = {}
    for name, s in sources(rec).items():
        ps = np.stack([np.interp(t, s["time"], s["position"][:, i]) for i in range(2)], -1)
        out[name] = np.degrees(true_bearing(ps[:, 0] - pa[:, 0], ps[:, 1] - pa[:, 1]))
    return out
