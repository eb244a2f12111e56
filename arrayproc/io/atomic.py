"""Write-then-rename: an output file appears whole or not at all, never over an input.

* :func:`check_output` refuses, before any work, an output path that is one of the inputs
  (the same file through a symlink or a hard link too: :func:`os.path.samefile`) or that names
  something other than a regular file (a directory, a device such as ``/dev/null``, a FIFO, a
  socket, the empty string).
* Every temporary file is registered while it lives; :func:`discard_all` removes those left
  when a run stops (an error, a signal), so no hidden ``.part`` file is left behind.
* A stop requested from a signal handler (:func:`request_stop`) is remembered here and checked
  by every writer on each append and before the final rename (:func:`check_stop`): even when the
  exception raised by the handler is swallowed (Python drops exceptions raised inside weakref
  callbacks and ``__del__``), the run stops at the next write and never commits its output.
"""

from __future__ import annotations

import os
import stat
import tempfile
import threading
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from arrayproc.errors import FormatError, Interrupted

_LIVE: set[Path] = set()
_LOCK = threading.Lock()
_STOP: list[int] = []  # signal numbers requested, first one wins
_GRACEFUL: list[bool] = [False]  # a live run ends its stream on a stop request


# -- stop requests ----------------------------------------------------------------------------
def request_stop(signum: int) -> None:
    """Remember that the run must stop (called from a signal handler)."""
    if not _STOP:
        _STOP.append(int(signum))


def stop_requested() -> int | None:
    """The signal number of a pending stop request, else None."""
    return _STOP[0] if _STOP else None


def clear_stop() -> None:
    """Forget a stop request (a new run in the same process)."""
    _STOP.clear()


def check_stop() -> None:
    """Raise :class:`Interrupted` when a stop was requested (not during a graceful run)."""
    if _STOP and not _GRACEFUL[0]:
        raise Interrupted(_STOP[0])


def set_graceful(on: bool) -> None:
    """A run that follows live input ends on the first stop request instead of raising:
    the signal handler only records it, :func:`check_stop` lets the writers finish and the
    run's source ends its stream (``process --follow``)."""
    _GRACEFUL[0] = bool(on)


def graceful() -> bool:
    """Whether stop requests end the stream instead of raising (:func:`set_graceful`)."""
    return _GRACEFUL[0]


# -- output paths -----------------------------------------------------------------------------
def check_output(output: str | os.PathLike, inputs: Iterable[str | os.PathLike] = ()) -> Path:
    """Refuse an output path that would destroy an input or is not a regular file.

    Parameters
    ----------
    output : path-like
        The file a command will write (replaced atomically when it exists).
    inputs : iterable of path-like
        Every file the command reads.

    Returns
    -------
    Path
        The output path.

    Raises
    ------
    FormatError
        The output is empty, names a directory, a device, a FIFO or a socket, or is the same
        file as an input (compared by device and inode, so symlinks and hard links count).
    """
    text = os.fspath(output)
    if not text.strip():
        raise FormatError("output path is empty")
    path = Path(text)
    if text.endswith(os.sep) or path.name in ("", ".", ".."):
        raise FormatError(f"{text}: output must be a file name, not a directory")
    try:
        st = os.stat(path)  # follows symlinks: what the target really is
    except FileNotFoundError:
        st = None
    except OSError as e:
        raise FormatError(f"{text}: cannot check the output path ({e.strerror})") from None
    if st is not None:
        if stat.S_ISDIR(st.st_mode):
            raise FormatError(f"{text}: is a directory; give a file name for the output")
        if not stat.S_ISREG(st.st_mode):
            kind = ("a device" if stat.S_ISCHR(st.st_mode) or stat.S_ISBLK(st.st_mode) else
                    "a FIFO" if stat.S_ISFIFO(st.st_mode) else
                    "a socket" if stat.S_ISSOCK(st.st_mode) else "not a regular file")
            raise FormatError(f"{text}: is {kind}; outputs must be regular files")
        for inp in inputs:
            if inp is None or not os.fspath(inp):
                continue
            try:
                same = os.path.samefile(path, inp)
            except OSError:
                continue
            if same:
                raise FormatError(f"{text}: output is the same file as the input {os.fspath(inp)}"
                                  "; refusing to overwrite an input")
    elif path.is_symlink():
        raise FormatError(f"{text}: is a dangling symbolic link; refusing to write through it")
    return path


# -- temporary files --------------------------------------------------------------------------
def temporary_sibling(target: str | os.PathLike) -> Path:
    """A fresh temporary path in the target's directory (so the final rename is atomic).

    The path is registered until :func:`commit` or :func:`discard`. Raises FormatError naming
    the directory when it does not exist or is not writable.
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
    tmp_path = Path(tmp)
    register(tmp_path)
    return tmp_path


def register(tmp: Path) -> None:
    """Track a temporary file so :func:`discard_all` removes it if the run stops."""
    with _LOCK:
        _LIVE.add(Path(tmp))


def commit(tmp: Path, target: str | os.PathLike) -> None:
    """Move the finished temporary file onto the target (unless a stop was requested)."""
    check_stop()
    os.replace(tmp, target)
    with _LOCK:
        _LIVE.discard(Path(tmp))


def discard(tmp: Path) -> None:
    """Remove a temporary file (or directory: a Zarr store) left by a failed write (no error
    if it is absent)."""
    try:
        if os.path.isdir(tmp) and not os.path.islink(tmp):
            import shutil
            shutil.rmtree(tmp, ignore_errors=True)
        else:
            os.unlink(tmp)
    except FileNotFoundError:
        pass
    with _LOCK:
        _LIVE.discard(Path(tmp))


def discard_all() -> list[Path]:
    """Remove every registered temporary file (end of a failed or interrupted run).

    Returns
    -------
    list of Path
        The files removed.
    """
    with _LOCK:
        live = list(_LIVE)
    for p in live:
        discard(p)
    return live


class AtomicH5Writer:
    """An HDF5 file written under a temporary name beside ``path``: :meth:`close` moves it into
    place, :meth:`abort` (or an exception inside a ``with`` block) removes it.

    Subclasses do their set-up in :meth:`_start`; when it fails, the temporary file is removed
    before the error propagates (a constructor never leaks a ``.part`` file).

    ``live=True`` writes ``path`` itself, readable while it grows: HDF5 single-writer /
    multiple-reader (SWMR) mode from the end of :meth:`_start` on, :meth:`flush` after each
    batch of rows; a reader opens it with ``h5py.File(path, "r", swmr=True)`` and
    ``refresh()``-es the datasets. The file is still removed on an error; a subclass marks it
    complete in :meth:`_finish`.
    """

    def __init__(self, path: str | os.PathLike, *args: Any, live: bool = False,
                 **kwargs: Any) -> None:
        import h5py
        self.path = Path(path)
        self.live = bool(live)
        check_stop()
        self._tmp = self.path if self.live else temporary_sibling(self.path)
        if self.live:
            register(self._tmp)
        try:
            self._f = h5py.File(self._tmp, "w", libver="latest") if self.live else \
                h5py.File(self._tmp, "w")
        except BaseException:
            discard(self._tmp)
            raise
        try:
            self._start(*args, **kwargs)
            if self.live:
                self._f.swmr_mode = True
        except BaseException:
            self.abort()
            raise

    def flush(self) -> None:
        """Write what was appended so far to disk (readers in SWMR mode then see it)."""
        self._f.flush()

    def _start(self) -> None:
        """Set-up of a subclass after the file is created."""

    def _finish(self) -> None:
        """Last writes before the file is closed (subclasses)."""

    def close(self) -> None:
        """Finish the file and move it into place."""
        try:
            check_stop()
            self._finish()
            self._f.close()
            if self.live:
                with _LOCK:
                    _LIVE.discard(self._tmp)
            else:
                commit(self._tmp, self.path)
        except BaseException:
            self.abort()
            raise

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
