"""Reading HDF5 files defensively: every failure (missing file, not HDF5, held by a writer,
dangling link, wrong type, a non-numeric or implausibly large dataset, an attribute that is not
one number) becomes one :class:`~arrayproc.errors.FormatError` naming the file and the object.

The readers of recordings, products and ``arrayproc info`` open files through :func:`open_h5`
and reach objects through :func:`get_object`.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from arrayproc.errors import FormatError


def open_h5(path: str | os.PathLike, what: str = "file", swmr: bool = False) -> h5py.File:
    """Open an HDF5 file read-only, turning every failure into one clear FormatError;
    ``swmr``: as a single-writer / multiple-reader reader of a file another process is
    writing in SWMR mode."""
    path = Path(path)
    if not path.exists():
        raise FormatError(f"{path}: no such {what}")
    if path.is_dir():
        raise FormatError(f"{path}: is a directory, not an HDF5 {what}")
    if not path.is_file():
        import stat
        mode = path.stat().st_mode
        kind = ("a FIFO" if stat.S_ISFIFO(mode) else "a socket" if stat.S_ISSOCK(mode)
                else "a device" if stat.S_ISCHR(mode) or stat.S_ISBLK(mode) else "special")
        raise FormatError(f"{path}: is {kind}, not a regular HDF5 {what}")
    try:
        if not h5py.is_hdf5(path):
            raise FormatError(f"{path}: not an HDF5 file")
        return h5py.File(path, "r", libver="latest", swmr=True) if swmr else h5py.File(path, "r")
    except FormatError:
        raise
    except PermissionError:
        raise FormatError(f"{path}: permission denied") from None
    except OSError as e:
        text = str(e)
        if "lock" in text or "already open" in text or "errno = 11" in text:
            raise FormatError(f"{path}: the file is held open by a writer (it may still be "
                              "being written); try again when the writer has finished") from None
        raise FormatError(f"{path}: cannot open HDF5 file (truncated or corrupt, or still "
                          f"being written?): {text.splitlines()[0] if text else e!r}") from None


def attr_str(v: Any) -> str:
    """An attribute as ``str`` (bytes decoded, a one-element array unwrapped)."""
    if isinstance(v, np.ndarray) and v.size == 1:
        v = v.reshape(-1)[0]
    return v.decode(errors="replace") if isinstance(v, bytes) else str(v)


def attr_number(p: Path, obj: Any, key: str, default: float | None = None) -> float:
    """A numeric attribute (a number or a one-element numeric array) as a float.

    Strings, empty arrays, arrays of several values and non-numeric types raise one
    FormatError naming the file and the attribute.
    """
    if key not in obj.attrs:
        if default is None:
            raise FormatError(f"{p}: attribute {key!r} is missing")
        return float(default)
    try:
        v = obj.attrs[key]
    except (OSError, TypeError, ValueError) as e:
        raise FormatError(f"{p}: attribute {key!r} cannot be read ({e})") from None
    a = np.asarray(v)
    if a.dtype.kind not in "fiub" or a.size != 1:
        raise FormatError(f"{p}: attribute {key!r} must be one number, got {_show(v)}")
    return float(a.reshape(-1)[0])


def _show(v: Any) -> str:
    text = repr(v)
    return text if len(text) <= 60 else text[:57] + "..."


def get_object(f: h5py.File, p: Path, name: str, kind: type | None = None) -> Any:
    """The object at ``name`` (None when absent); dangling soft or external links and objects
    of the wrong kind (a dataset where a group belongs, or the reverse) raise FormatError."""
    try:
        link = f.get(name, getlink=True)
    except (KeyError, OSError, ValueError, TypeError):
        link = None
    if link is None:
        return None
    try:
        obj = f[name]
    except (KeyError, OSError, ValueError) as e:
        what = ("external link" if isinstance(link, h5py.ExternalLink) else "soft link"
                if isinstance(link, h5py.SoftLink) else "object")
        raise FormatError(f"{p}: /{name.lstrip('/')} is a dangling {what} ({e})") from None
    if kind is not None and not isinstance(obj, kind):
        want = "a group" if kind is h5py.Group else "a dataset"
        raise FormatError(f"{p}: /{name.lstrip('/')} must be {want}")
    return obj


def read_numeric(f: h5py.File, p: Path, name: str, required: bool = False) -> np.ndarray | None:
    """A numeric dataset as a float64 array (None when absent and not required)."""
    d = get_object(f, p, name, h5py.Dataset)
    if d is None:
        if required:
            raise FormatError(f"{p}: /{name} is missing")
        return None
    if d.dtype.kind not in "fiub":
        raise FormatError(f"{p}: /{name} must be numeric, has type {d.dtype}")
    if d.size > 50_000_000:
        raise FormatError(f"{p}: /{name} is implausibly large ({d.shape})")
    try:
        return np.asarray(d[()], dtype=float)
    except (OSError, ValueError, TypeError) as e:
        raise FormatError(f"{p}: /{name} cannot be read ({e})") from None


_attr_str = attr_str  # the name the readers used before this module existed
