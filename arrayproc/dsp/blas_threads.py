"""Per-thread control of OpenBLAS threading.

The CBF runs many small GEMMs (one per frequency bin) and splits the bins over a few worker
threads. OpenBLAS's own threading on such small matrices costs more than it gains (measured:
about 3x slower on this project's 2-core machine), so each worker asks for a single BLAS
thread with ``openblas_set_num_threads_local`` (OpenBLAS >= 0.3.27), which affects only the
calling thread. When the symbol cannot be found the call is a no-op.
"""

from __future__ import annotations

import ctypes
import glob
import os

import numpy as np

_setter = None
_searched = False


def _find() -> object:
    global _setter, _searched
    if _searched:
        return _setter
    _searched = True
    root = os.path.dirname(np.__file__)
    cands = glob.glob(os.path.join(root, "..", "numpy.libs", "*openblas*.so*"))
    cands += glob.glob(os.path.join(root, ".dylibs", "*openblas*"))
    for path in cands:
        try:
            lib = ctypes.CDLL(path)
            f = lib.openblas_set_num_threads_local
        except (OSError, AttributeError):
            continue
        f.argtypes = [ctypes.c_int]
        f.restype = ctypes.c_int
        _setter = f
        break
    return _setter


def set_local_threads(n: int) -> int | None:
    """Set the BLAS thread count for the calling thread; returns the previous one (or None)."""
    f = _find()
    if f is None:
        return None
    return int(f(int(n)))


def available() -> bool:
    """Whether per-thread BLAS control works here."""
    return _find() is not None
