"""Helpers of the delay plots (detections, delays, positions) and of the plots of a
recording (spectrogram, geometry): product lookup by kind and the recording a products file
was made from."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from arrayproc.errors import ArrayprocError, FormatError


def groups_of(path: str, kind: str) -> tuple[list[tuple[str, dict[str, Any]]], dict[str, Any]]:
    """Every products group of ``kind`` (name, columns) and the root attributes."""
    from arrayproc.io.products import read_products
    prod = read_products(path)
    found = list(prod.groups(kind).items())
    if not found:
        raise ArrayprocError(f"{path}: no {kind} product (kinds: "
                             f"{', '.join(sorted(set(prod.kinds())))})")
    return found, prod.root


def source_recording(root: dict[str, Any], path: str, what: str):
    """Open the recording named by the products' ``source`` attribute."""
    src = root.get("source", "")
    src = src.decode() if isinstance(src, bytes) else str(src)
    if not src or not Path(src).is_file():
        raise ArrayprocError(f"{path}: the {what} plot needs the recording it was made from "
                             f"(source {src!r} not found)")
    from arrayproc.io.recording import Recording
    try:
        return Recording(src)
    except FormatError as e:
        raise ArrayprocError(f"{path}: cannot open its source recording ({e})") from None


def open_recording(path: str, what: str):
    """The recording at ``path``, or, for a products file, the recording it was made from
    (its ``source``): the plots of samples and of the array take either."""
    from arrayproc.io.h5 import attr_str, open_h5
    from arrayproc.io.products import FORMAT
    with open_h5(path, "recording or products file") as f:
        root = dict(f.attrs)
        products = attr_str(root.get("format", "")) == FORMAT
    if products:
        return source_recording(root, path, what)
    from arrayproc.io.recording import Recording
    return Recording(path)


def ellipse(cov2: np.ndarray, centre: np.ndarray, n_sigma: float = 1.0,
            n: int = 64) -> np.ndarray:
    """Points (n, 2) of the n-sigma ellipse of a 2-D covariance around ``centre``."""
    w, v = np.linalg.eigh(np.asarray(cov2, float))
    a = np.linspace(0, 2 * np.pi, n)
    circle = np.stack([np.cos(a), np.sin(a)])
    return (v @ (np.sqrt(np.maximum(w, 0))[:, None] * circle)).T * n_sigma + centre
