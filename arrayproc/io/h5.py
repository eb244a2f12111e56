"""Reading HDF5 files defensively: every failure (missing file, not HDF5, truncated, a damaged
superblock or metadata, held by a writer, a writer that died, dangling link, wrong type, a
non-numeric or implausibly large dataset, an attribute that is not one number) becomes one
:class:`~arrayproc.errors.FormatError` naming the file and the object.

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
    writing in SWMR mode.

    Damaged files are told apart (:func:`open_error`): a truncated file, a damaged superblock
    or signature, damaged metadata, a file a writer holds locked, a file marked open by a
    SWMR writer that is alive or one that died.
    """
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
            raise FormatError(not_hdf5(path))
        return h5py.File(path, "r", libver="latest", swmr=True) if swmr else h5py.File(path, "r")
    except FormatError:
        raise
    except PermissionError:
        raise FormatError(f"{path}: permission denied") from None
    except OSError as e:
        raise FormatError(open_error(path, e)) from None


#: The 8-byte signature that starts an HDF5 superblock.
SIGNATURE = b"\x89HDF\r\n\x1a\n"


def not_hdf5(path: Path) -> str:
    """Why a file without the HDF5 signature is refused: empty, a damaged signature (at most
    3 bits away from HDF5's), or another format."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(8)
    except OSError as e:
        return f"{path}: cannot be read ({e.strerror})"
    if not head:
        return f"{path}: is empty (0 bytes), not an HDF5 file"
    if len(head) == 8:
        flips = sum(bin(a ^ b).count("1") for a, b in zip(head, SIGNATURE))
        if flips <= 3:
            return (f"{path}: corrupt superblock: its HDF5 signature is damaged ({flips} "
                    "bit(s) differ); the file cannot be read")
    return f"{path}: not an HDF5 file"


def open_error(path: Path, e: OSError) -> str:
    """The one-line reason HDF5 could not open ``path`` (the text of its error, classified)."""
    import re
    text = str(e)
    first = text.splitlines()[0] if text else repr(e)
    reason = re.sub(r"^Unable to (synchronously )?open file \((.*)\)$", r"\2", first)
    if "unable to lock file" in text or e.errno == 11:
        who = _holders(path)
        return (f"{path}: the file is held open by a writer{who} (it may still be being "
                "written: HDF5's lock is held); try again when the writer has finished")
    if "already open for write" in text:
        who = _holders(path)
        if who:
            return (f"{path}: the file is being written by a live writer{who} (HDF5 SWMR); "
                    "read it as it grows with  arrayproc process --follow")
        return (f"{path}: the file is marked open for writing, but no process on this machine "
                "has it open: its writer stopped before closing it, so it may be incomplete "
                f"(h5clear -s {path} removes the mark)")
    m = re.search(r"truncated file: eof = (\d+), sblock->base_addr = (\d+), "
                  r"stored_eof = (\d+)", text)
    if m:
        eof, base, stored = (int(g) for g in m.groups())
        if stored >= 1 << 48 or stored > 4 * (eof + base) + (1 << 20):
            return (f"{path}: corrupt superblock: it records an end of file at {stored} bytes, "
                    f"the file has {eof}; the file cannot be read")
        return (f"{path}: truncated file: {eof} of the {stored - base} bytes its superblock "
                f"records are present (an interrupted copy or write){_prefix(path, stored)}; "
                "the file cannot be read as it is")
    if "superblock" in text or "signature" in text or "get_eoa" in text or \
            "temporary file space" in text:
        return f"{path}: corrupt superblock ({reason}); the file cannot be read"
    return f"{path}: damaged HDF5 metadata ({reason}); the file cannot be read"


def _prefix(path: Path, stored: int) -> str:
    """``; /time_data is whole up to t = 12.3 s of 40.0 s`` for a truncated recording."""
    got = truncated_rows(path, "time_data", stored)
    if got is None:
        return ""
    ok, total, fs = got
    if fs and fs > 0:
        return (f"; its samples are whole up to t = {ok / fs:.3f} s of {total / fs:.3f} s "
                f"(sample {ok} of {total})")
    return f"; /time_data is whole up to row {ok} of {total}"


def _holders(path: Path) -> str:
    """`` (process 123)`` when processes on this machine have ``path`` open (Linux: their
    ``/proc/PID/fd``), else the empty string."""
    try:
        st = os.stat(path)
    except OSError:
        return ""
    pids = []
    proc = Path("/proc")
    if not proc.is_dir():
        return ""
    me = os.getpid()
    for d in proc.iterdir():
        if not d.name.isdigit() or int(d.name) == me:
            continue
        try:
            for fd in (d / "fd").iterdir():
                try:
                    fst = os.stat(fd)
                except OSError:
                    continue
                if fst.st_ino == st.st_ino and fst.st_dev == st.st_dev:
                    pids.append(int(d.name))
                    break
        except OSError:
            continue
    if not pids:
        return ""
    return f" (process {', '.join(str(p) for p in sorted(pids)[:3])})"


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


# -- damaged datasets ---------------------------------------------------------------------------
def stored_rows(d: h5py.Dataset) -> int | None:
    """Rows of a chunked dataset (chunks along the first axis) before its first chunk that was
    never written, or None when every chunk is there (or the layout is not chunked by rows).

    A writer that died after growing the dataset but before writing its chunks leaves such a
    hole; HDF5 reads it as the fill value (zeros), so it must be found before reading.
    """
    chunks = d.chunks
    if chunks is None or d.ndim < 1 or d.shape[0] == 0:
        return None
    if any(c < n for c, n in zip(chunks[1:], d.shape[1:])):
        return None  # several chunks per row: not checked
    rows = int(chunks[0])
    want = -(-int(d.shape[0]) // rows)
    try:
        have = d.id.get_num_chunks()
        if have >= want:
            return None
        starts = sorted(int(d.id.get_chunk_info(i).chunk_offset[0]) // rows
                        for i in range(have))
    except (OSError, ValueError, RuntimeError):
        return None
    for k, s in enumerate(starts):
        if s != k:
            return k * rows
    return len(starts) * rows


def first_bad_row(d: h5py.Dataset, start: int, stop: int) -> tuple[int, str]:
    """The first row in ``[start, stop)`` whose chunk cannot be read (a failed checksum or
    decompression, a chunk beyond the file's end), and HDF5's reason.

    Returns ``(stop, "")`` when every row reads.
    """
    rows = int(d.chunks[0]) if d.chunks else max(1, stop - start)
    a = start
    while a < stop:
        b = min(stop, (a // rows + 1) * rows)
        try:
            d[a:b]
        except (OSError, ValueError, RuntimeError) as e:
            text = str(e).splitlines()[0] if str(e) else type(e).__name__
            return a, text
        a = b
    return stop, ""


def damage_reason(text: str) -> str:
    """HDF5's read error in words."""
    if "filter returned failure" in text or "checksum" in text:
        return "a chunk's checksum or compression check fails (bit flips or overwritten bytes)"
    if "past end" in text or "addr overflow" in text or "eoa" in text:
        return "a chunk lies beyond the end of the file (truncated)"
    return f"a chunk cannot be read ({text})"


def truncated_rows(path: str | os.PathLike, name: str,
                   stored_eof: int) -> tuple[int, int, float | None] | None:
    """For a truncated file: ``(rows readable, rows declared, sample_freq or None)`` of the
    dataset ``name``, read
    with the file presented at its recorded length (zeros past the real end) and the chunks
    that lie wholly before the real end counted in order; None when the dataset's metadata is
    itself beyond the end."""
    size = os.path.getsize(path)
    try:
        with open(path, "rb") as raw, h5py.File(_Padded(raw, size, stored_eof), "r") as f:
            d = f[name]
            if not isinstance(d, h5py.Dataset) or d.chunks is None or d.ndim < 1:
                return None
            rows = int(d.chunks[0])
            ok: list[int] = []
            for i in range(d.id.get_num_chunks()):
                info = d.id.get_chunk_info(i)
                if info.byte_offset + info.size <= size:
                    ok.append(int(info.chunk_offset[0]) // rows)
            n = 0
            for k in sorted(ok):
                if k != n:
                    break
                n += 1
            fs = d.attrs.get("sample_freq")
            fs = float(np.asarray(fs).reshape(-1)[0]) if fs is not None and \
                np.asarray(fs).dtype.kind in "fiu" and np.asarray(fs).size == 1 else None
            return min(n * rows, int(d.shape[0])), int(d.shape[0]), fs
    except (OSError, KeyError, ValueError, RuntimeError, TypeError):
        return None


class _Padded:
    """A read-only file object of ``length`` bytes: the file's own, then zeros."""

    def __init__(self, raw: Any, size: int, length: int) -> None:
        self._raw, self._size, self._len, self._pos = raw, size, max(size, length), 0

    def seek(self, offset: int, whence: int = 0) -> int:
        self._pos = offset if whence == 0 else self._pos + offset if whence == 1 \
            else self._len + offset
        return self._pos

    def tell(self) -> int:
        return self._pos

    def readinto(self, b: Any) -> int:
        m = memoryview(b).cast("B")
        n = min(len(m), max(0, self._len - self._pos))
        got = 0
        if self._pos < self._size:
            self._raw.seek(self._pos)
            got = self._raw.readinto(m[:min(n, self._size - self._pos)]) or 0
        m[got:n] = bytes(n - got)
        self._pos += n
        return n

    def read(self, n: int = -1) -> bytes:
        buf = bytearray(max(0, self._len - self._pos) if n < 0 else n)
        return bytes(buf[:self.readinto(buf)])

    def write(self, b: Any) -> int:
        raise OSError("read-only")

    def truncate(self, size: int | None = None) -> int:
        raise OSError("read-only")

    def flush(self) -> None:
        pass
