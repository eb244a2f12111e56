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
* Write failures of the environment (disk full, quota, I/O error, read-only file system):
  every HDF5 output is written through a :class:`GuardedFile` (h5py's file-object driver).
  Its first failed write is recorded, and from then on nothing more reaches the disk: later
  writes go to a small memory overlay, so the HDF5 library sees no error, its objects and
  caches close normally (no exception in h5py's finalisers, no crash at exit) and the
  temporary file is then removed. :func:`check_stop`, which every writer calls on each
  append and before the rename, raises :class:`~arrayproc.errors.OutputWriteError` naming the
  output and the reason. Text outputs use :func:`atomic_path`, which turns the same failures
  into the same error. The finished file and its folder are flushed to the disk (``fsync``)
  before and after the rename, so a power loss leaves the old output or the new one.
* A killed run (SIGKILL, power loss) can leave only its hidden ``.NAME.*.part`` file: the
  writer holds an exclusive ``flock`` on it while it lives, and the next run of the same
  output removes every such file nobody holds (:func:`remove_stale_parts`).
* :func:`check_free_space` refuses, before any work, an output whose size is known
  (``simulate``, ``import``) when its folder has less room.

Why hand-written: HDF5's own POSIX driver reports a failed write as an error on every later
flush and close, and h5py then raises inside object finalisers, where no caller can catch
it; the process ends in a segmentation fault or an abort. A Python file object is the only
place where the write can be watched and the library kept consistent.
"""

from __future__ import annotations

import contextlib
import errno as _errno
import os
import stat
import tempfile
import threading
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

from arrayproc.errors import FormatError, Interrupted, OutputWriteError

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
    clear_errors()


def in_file_driver(frame: Any) -> bool:
    """Whether ``frame`` (a signal handler's) runs inside a :class:`GuardedFile` method, that
    is, in HDF5's C file driver calling back into Python. An exception raised there cannot
    unwind through HDF5: h5py turns it into a ``SystemError`` with a traceback and may leave
    its objects half-freed, so a stop there is only recorded; :func:`check_stop`, called
    by every writer between writes and before :func:`commit`, raises it next."""
    codes = _driver_codes()
    depth = 0
    while frame is not None and depth < 8:
        if frame.f_code in codes:
            return True
        frame, depth = frame.f_back, depth + 1
    return False


def _driver_codes() -> frozenset:
    if not _DRIVER_CODES:
        _DRIVER_CODES.append(frozenset(
            f.__code__ for f in vars(GuardedFile).values() if hasattr(f, "__code__")))
    return _DRIVER_CODES[0]


_DRIVER_CODES: list[frozenset] = []


def check_stop() -> None:
    """Raise :class:`Interrupted` when a stop was requested (not during a graceful run), and
    :class:`~arrayproc.errors.OutputWriteError` when a live output's write failed
    (:class:`GuardedFile`) or a stop was requested by the memory guard."""
    if _STOP and not _GRACEFUL[0]:
        raise Interrupted(_STOP[0])
    if _FAULTS:
        with _LOCK:
            first = next(iter(_FAULTS.values()), None)
        if first is not None:
            raise first
    if _ERRORS:
        raise _ERRORS[0]


_ERRORS: list[BaseException] = []  # errors requested from another thread (memory guard)


def request_error(err: BaseException) -> None:
    """Make the next :func:`check_stop` raise ``err`` (a watchdog thread stopping the run)."""
    if not _ERRORS:
        _ERRORS.append(err)


def clear_errors() -> None:
    """Forget requested errors and recorded write faults (a new run in the same process)."""
    _ERRORS.clear()
    with _LOCK:
        _FAULTS.clear()


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
    remove_stale_parts(target)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".part", dir=directory)
    except OSError as e:
        if e.errno in WRITE_ERRNOS:
            raise OutputWriteError(str(target), e) from None
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
    """Move the finished temporary file onto the target (unless a stop was requested), its
    data and then the folder's entry flushed to the disk (a power loss leaves either file)."""
    check_stop()
    try:
        _fsync_path(tmp)
        os.replace(tmp, target)
        _fsync_path(Path(target).parent if str(Path(target).parent) else Path("."))
    except OSError as e:
        if e.errno in WRITE_ERRNOS:
            raise OutputWriteError(str(target), e) from None
        raise
    with _LOCK:
        _LIVE.discard(Path(tmp))


def _fsync_path(p: Path) -> None:
    """fsync a file or a folder (folders: where the platform allows opening one)."""
    try:
        fd = os.open(p, os.O_RDONLY)
    except (IsADirectoryError, PermissionError):
        return
    try:
        os.fsync(fd)
    except OSError as e:
        if e.errno not in (_errno.EINVAL, _errno.EBADF, _errno.ENOTSUP):
            raise
    finally:
        os.close(fd)


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


# -- write failures -----------------------------------------------------------------------------
#: errno values that mean "the environment cannot take this output" (exit status 74).
WRITE_ERRNOS = frozenset(getattr(_errno, n) for n in (
    "ENOSPC", "EDQUOT", "EIO", "EROFS", "EFBIG", "ENXIO", "ESTALE", "EREMOTEIO")
    if hasattr(_errno, n))

_FAULTS: dict[int, OutputWriteError] = {}  # id(GuardedFile) -> its first write failure

#: Test hook: ``ERRNAME@BYTES`` (e.g. ``ENOSPC@20000``) makes every write of a guarded output
#: that would take this process's guarded bytes beyond BYTES fail with that errno, as a disk
#: that fills up would. Read once per process; used by the fault-injection suite only.
FAULT_ENV = "ARRAYPROC_FAULT_INJECT"
_INJECT: list[Any] = []  # [errno, limit, bytes so far] once parsed; [None] when unset


def _injected(n: int) -> int | None:
    """The errno a write of ``n`` bytes must fail with under :data:`FAULT_ENV`, else None."""
    if not _INJECT:
        spec = os.environ.get(FAULT_ENV, "")
        name, _, limit = spec.partition("@")
        code = getattr(_errno, name.strip(), None) if spec else None
        try:
            _INJECT[:] = [code, int(limit), 0] if code else [None]
        except ValueError:
            _INJECT[:] = [None]
    if _INJECT[0] is None:
        return None
    if _INJECT[2] + n > _INJECT[1]:
        _INJECT[1] = -1  # a full disk stays full
        return _INJECT[0]
    _INJECT[2] += n
    return None


class GuardedFile:
    """The binary file an HDF5 output is written to (h5py's ``fileobj`` driver), which stops
    reaching the disk at its first failed write.

    The failure is recorded (:attr:`fault`, raised by :func:`check_stop` and by
    :meth:`check`); the bytes of that write and of every later one go to an in-memory overlay
    that later reads see, so the library's view of the file stays consistent until it is
    closed and the file removed. The file holds an exclusive ``flock`` while it is open
    (:func:`remove_stale_parts` leaves it alone).

    Parameters
    ----------
    path : path-like
        The temporary file (created, truncated).
    output : str
        The output it becomes (named in the error).
    """

    def __init__(self, path: str | os.PathLike, output: str) -> None:
        self.path = Path(path)
        self.output = str(output)
        self._fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_TRUNC, 0o644)
        _lock(self._fd)
        self._pos = 0
        self._size = 0
        self._overlay: list[tuple[int, bytes]] = []
        self.fault: OutputWriteError | None = None

    # the file-object interface h5py's driver calls
    def seek(self, offset: int, whence: int = 0) -> int:
        """Move the position (``whence`` 0, 1, 2 as :func:`os.lseek`)."""
        self._pos = (offset if whence == 0 else self._pos + offset if whence == 1
                     else self._size + offset)
        return self._pos

    def tell(self) -> int:
        """The position."""
        return self._pos

    def readinto(self, b: Any) -> int:
        """Read at the position into ``b`` (the disk's bytes, then the overlay's on top)."""
        m = memoryview(b).cast("B")
        n = len(m)
        data = os.pread(self._fd, n, self._pos) if self._pos < self._size else b""
        got = len(data)
        m[:got] = data
        for off, chunk in self._overlay:
            lo, hi = max(off, self._pos), min(off + len(chunk), self._pos + n)
            if lo < hi:
                if lo - self._pos > got:
                    m[got:lo - self._pos] = bytes(lo - self._pos - got)
                m[lo - self._pos:hi - self._pos] = chunk[lo - off:hi - off]
                got = max(got, hi - self._pos)
        self._pos += got
        return got

    def read(self, n: int = -1) -> bytes:
        """Read ``n`` bytes at the position."""
        buf = bytearray(max(0, self._size - self._pos) if n < 0 else n)
        got = self.readinto(buf)
        return bytes(buf[:got])

    def write(self, b: Any) -> int:
        """Write at the position; after a failure, to the overlay only."""
        m = memoryview(b).cast("B")
        n = len(m)
        if self.fault is None:
            try:
                code = _injected(n)
                if code is not None:
                    raise OSError(code, os.strerror(code))
                done = 0
                while done < n:
                    done += os.pwrite(self._fd, m[done:], self._pos + done)
            except OSError as e:
                self._record(e)
        if self.fault is not None:
            self._overlay.append((self._pos, bytes(m)))
        self._pos += n
        self._size = max(self._size, self._pos)
        return n

    def truncate(self, size: int | None = None) -> int:
        """Set the length (on the disk only before a failure)."""
        size = self._pos if size is None else int(size)
        if self.fault is None:
            try:
                os.ftruncate(self._fd, size)
            except OSError as e:
                self._record(e)
        self._size = size
        return size

    def flush(self) -> None:
        """Nothing to flush: writes go straight to the descriptor."""

    # the writer's side
    def _record(self, e: OSError) -> None:
        self.fault = OutputWriteError(self.output, e)
        with _LOCK:
            _FAULTS.setdefault(id(self), self.fault)

    def check(self) -> None:
        """Raise the recorded write failure, if any."""
        if self.fault is not None:
            raise self.fault

    def sync(self) -> None:
        """Flush the data to the disk (a failure is recorded and raised)."""
        if self.fault is None:
            try:
                os.fsync(self._fd)
            except OSError as e:
                if e.errno not in (_errno.EINVAL, _errno.ENOTSUP):
                    self._record(e)
        self.check()

    def close(self) -> None:
        """Close the descriptor (releasing the lock) and forget the failure."""
        if self._fd >= 0:
            os.close(self._fd)
            self._fd = -1
        self._overlay.clear()
        with _LOCK:
            _FAULTS.pop(id(self), None)

    @property
    def closed(self) -> bool:
        """Whether :meth:`close` was called."""
        return self._fd < 0


def _lock(fd: int) -> None:
    """An exclusive advisory lock on an open temporary file (no-op where flock is missing)."""
    try:
        import fcntl
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except (ImportError, OSError):
        pass


def remove_stale_parts(target: str | os.PathLike) -> list[Path]:
    """Remove the temporary files ``.NAME.*.part`` beside ``target`` that a killed run left
    (those no live writer holds locked).

    Returns
    -------
    list of Path
        The files removed.
    """
    target = Path(target)
    directory = target.parent if str(target.parent) else Path(".")
    removed = []
    try:
        candidates = [*directory.glob(f".{glob_escape(target.name)}.*.part"),
                      *directory.glob(f".{glob_escape(target.name)}.*.part.*")]
    except OSError:
        return removed
    for p in candidates:
        with _LOCK:
            if p in _LIVE:
                continue
        try:
            fd = os.open(p, os.O_RDONLY)
        except OSError:
            continue
        try:
            import fcntl
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except ImportError:
            pass
        except OSError:  # held by a live writer
            os.close(fd)
            continue
        try:
            os.unlink(p)
            removed.append(p)
        except OSError:
            pass
        finally:
            os.close(fd)
    return removed


def glob_escape(name: str) -> str:
    """``name`` with the glob metacharacters ``*?[`` made literal."""
    import glob
    return glob.escape(name)


def free_bytes(directory: str | os.PathLike) -> float:
    """Bytes an unprivileged process may still write in ``directory`` (inf when unknown)."""
    try:
        st = os.statvfs(directory)
    except (OSError, AttributeError):
        return float("inf")
    return float(st.f_bavail) * float(st.f_frsize)


def check_free_space(output: str | os.PathLike, nbytes: float, margin: float = 1.02,
                     slack: float = 1 << 20) -> None:
    """Refuse an output of a known size (``nbytes``) that its folder cannot hold.

    Parameters
    ----------
    output : path-like
        The output file.
    nbytes : float
        Its expected size, bytes.
    margin, slack : float
        Needed space: ``nbytes * margin + slack`` (HDF5's metadata, the chunk index).

    Raises
    ------
    OutputWriteError
        The folder has less free space than needed (ENOSPC, before any work).
    """
    output = Path(output)
    directory = output.parent if str(output.parent) else Path(".")
    need = float(nbytes) * margin + slack
    have = free_bytes(directory)
    if have < need:
        err = OSError(_errno.ENOSPC, os.strerror(_errno.ENOSPC))
        e = OutputWriteError(str(output), err)
        e.args = (f"{output}: needs about {_mib(need)} but {directory} has {_mib(have)} free; "
                  "nothing was written (free space in the output's folder or give another -o)",)
        raise e


def _mib(n: float) -> str:
    return f"{n / (1 << 20):.1f} MiB"


@contextlib.contextmanager
def atomic_path(output: str | os.PathLike, suffix: str = "") -> Iterator[Path]:
    """A temporary path beside ``output`` for a writer that takes a file name (text exports,
    images): moved onto ``output`` when the block ends without error, removed otherwise; a
    write failure of the environment becomes :class:`~arrayproc.errors.OutputWriteError`.

    Parameters
    ----------
    output : path-like
        The file to write.
    suffix : str
        Extra suffix of the temporary name (e.g. ``".png"`` for a writer that picks its
        format from the name).

    Yields
    ------
    Path
        Where to write.
    """
    tmp = temporary_sibling(output)
    if suffix:
        with _LOCK:
            _LIVE.discard(tmp)
        tmp = tmp.with_name(tmp.name + suffix)
        register(tmp)
    fd = os.open(tmp, os.O_RDWR | os.O_CREAT, 0o644)
    _lock(fd)  # the part is live: remove_stale_parts leaves it alone
    try:
        yield tmp
        commit(tmp, output)
    except OSError as e:
        discard(tmp)
        if e.errno in WRITE_ERRNOS:
            raise OutputWriteError(str(output), e) from None
        raise
    except BaseException:
        discard(tmp)
        raise
    finally:
        os.close(fd)


#: Lowest HDF5 format version of the files the writers create (``h5py.File(libver=...)``):
#: 1.8's, with checksummed superblock and object headers (any HDF5 since 2008 reads it).
LIBVER = "v108"


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
        self._fh: GuardedFile | None = None
        self._f: Any = None
        check_stop()
        self._tmp = self.path if self.live else temporary_sibling(self.path)
        if self.live:
            register(self._tmp)
        try:
            if self.live:  # SWMR needs HDF5's own POSIX driver
                self._f = h5py.File(self._tmp, "w", libver="latest")
            else:
                self._fh = GuardedFile(self._tmp, str(self.path))
                # HDF5 1.8's format: superblock and object headers carry checksums, so a
                # damaged file is refused by name instead of read wrong
                self._f = h5py.File(self._fh, "w", libver=LIBVER)
        except OSError as e:
            self._drop()
            if e.errno in WRITE_ERRNOS:
                raise OutputWriteError(str(self.path), e) from None
            raise
        except BaseException:
            self._drop()
            raise
        try:
            self._start(*args, **kwargs)
            self.check()
            if self.live:
                self._f.swmr_mode = True
        except BaseException:
            self.abort()
            raise

    def check(self) -> None:
        """Raise :class:`~arrayproc.errors.OutputWriteError` when a write of this file failed
        (and :func:`check_stop`'s errors)."""
        if self._fh is not None:
            self._fh.check()
        check_stop()

    def flush(self) -> None:
        """Write what was appended so far to disk (readers in SWMR mode then see it)."""
        try:
            self._f.flush()
        except OSError as e:
            if e.errno in WRITE_ERRNOS or self.live:
                raise OutputWriteError(str(self.path), _as_oserror(e)) from None
            raise
        self.check()

    def _start(self) -> None:
        """Set-up of a subclass after the file is created."""

    def _finish(self) -> None:
        """Last writes before the file is closed (subclasses)."""

    def close(self) -> None:
        """Finish the file and move it into place (its data flushed to the disk first)."""
        try:
            self.check()
            self._finish()
            self._f.close()
            if self._fh is not None:
                self._fh.sync()  # raises a failure of the last writes or of the flush
            if self.live:
                with _LOCK:
                    _LIVE.discard(self._tmp)
            else:
                commit(self._tmp, self.path)
                self._fh.close()
        except OSError as e:  # the live file's own driver
            self.abort()
            if e.errno in WRITE_ERRNOS or self.live:
                raise OutputWriteError(str(self.path), _as_oserror(e)) from None
            raise
        except BaseException:
            self.abort()
            raise

    def abort(self) -> None:
        """Drop the partial file: every HDF5 object closed first, then the file removed."""
        try:
            if getattr(self, "_f", None) is not None:
                self._f.close()
        except Exception:  # noqa: BLE001 - the file is being dropped; its errors do not matter
            pass
        finally:
            self._drop()

    def _drop(self) -> None:
        if self._fh is not None:
            self._fh.close()
        discard(self._tmp)

    def __enter__(self) -> Any:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()


def _as_oserror(e: OSError) -> OSError:
    """An OSError with the errno HDF5 reports in its message (``errno = 28``) when h5py's
    exception has none."""
    if e.errno:
        return e
    import re
    m = re.search(r"errno = (\d+)", str(e))
    code = int(m.group(1)) if m else _errno.EIO
    return OSError(code, os.strerror(code))
