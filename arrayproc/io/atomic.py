"""Write-then-rename: an output file appears whole or not at all."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from ..errors import FormatError


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
