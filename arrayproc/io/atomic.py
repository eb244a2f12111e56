"""Write-then-rename: an output file appears whole or not at all."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import Any

import h5py

from arrayproc.errors import FormatError


def temporary_sibling(target: str | os.PathLike) -> Path:
    """A fresh temporary path in the target's directory (so the final rename is atomic).

    Raises FormatError naming the directory when it does not exist or is not writable.
    """
    target = Path(target)
    directory = target.parent if str(target.parent) else Path(".")
    if not directory.is_dir():
        raise FormatError(f"{target}: output directory {directory} does not exist")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".part", dir=directory)
    except OSError as e:
        raise FormatError(f"{target}: cannot write in {directory}: {e.strerror}") from None
    os.close(fd)
    os.unlink(tmp)  # h5py creates the file itself
    return Path(tmp)


def commit(tmp: Path, target: str | os.PathLike) -> None:
    """Move the finished temporary file onto the target."""
    os.replace(tmp, target)


def discard(tmp: Path) -> None:
    """Remove a temporary file left by a failed write (no error if it is absent)."""
    try:
        os.unlink(tmp)
    except FileNotFoundError:
        pass


class AtomicH5Writer:
    """An HDF5 file written under a temporary name beside ``path``: :meth:`close` moves it into
    place, :meth:`abort` (or an exception inside a ``with`` block) removes it."""

    def __init__(self, path: str | os.PathLike) -> None:
        self.path = Path(path)
        self._tmp = temporary_sibling(self.path)
        self._f = h5py.File(self._tmp, "w")

    def _finish(self) -> None:
        """Last writes before the file is closed (subclasses)."""

    def close(self) -> None:
        """Finish the file and move it into place."""
        self._finish()
        self._f.close()
        commit(self._tmp, self.path)

    def abort(self) -> None:
        """Drop the partial file."""
        try:
            self._f.close()
        finally:
            discard(self._tmp)

    def __enter__(self) -> Any:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()
