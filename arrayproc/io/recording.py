"""Recording files (docs/formats.md): a streaming reader into blocks and a streaming writer.

The reader pulls ``/time_data`` by HDF5 hyperslabs of a fixed size (a few MB), so memory is
bounded by the slab and block sizes, never by the file length. Files in acoular's layout (only
``/time_data`` with ``sample_freq``) open too, with the geometry given by the caller.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from arrayproc.errors import FormatError
from arrayproc.geo.nav import Nav
from arrayproc.geo.pose import Pose
from arrayproc.io.atomic import AtomicH5Writer, check_stop
from arrayproc.io.geometry import body_to_world
from arrayproc.io.units import file_units

FORMAT = "arrayproc.recording"
FORMAT_VERSION = 1
DEFAULT_SOUND_SPEED = 1500.0


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


def _attr_str(v: Any) -> str:
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


@dataclass(frozen=True)
class Replica:
    """A transmitted waveform from ``/active/waveforms/<name>`` (docs/formats.md).

    ``samples`` float64 at ``fs`` (the recording's rate), sample 0 at the transmission start;
    ``kind`` (bpsk, hfm, cw, lfm or other), ``fc`` centre frequency (Hz), ``bandwidth`` (Hz),
    ``duration`` (s), ``bits`` (BPSK, else 0).
    """

    samples: np.ndarray
    fs: float
    kind: str
    fc: float
    bandwidth: float
    duration: float
    bits: int = 0


@dataclass(frozen=True)
class ActivePings:
    """The ping schedule of ``/active``: transmission times (s), the waveform name of each
    ping, the replicas by name and the projector's body-frame position (m)."""

    time: np.ndarray
    waveform: list[str]
    waveforms: dict[str, Replica]
    projector: np.ndarray


class Recording:
    """A hydrophone recording opened for streaming.

    Parameters
    ----------
    path : path-like
        HDF5 recording (arrayproc format version 1, or acoular's layout).
    positions : (n_channels, 3) array, optional
        Element positions (body frame, m) overriding or supplying ``/array/positions``
        (required when the file has none and more than one channel).
    nan : {"error", "zero"}
        What to do with NaN/Inf samples: stop with an error naming the sample (default), or
        replace them with zeros and count them in ``n_nonfinite``.
    sound_speed : float, optional
        Overrides the file's ``sound_speed`` attribute (m/s).

    Channel gains (``/array/gains``) are applied and dead channels (``/array/dead``) dropped
    in every block; ``positions``, ``n_channels`` and ``channels`` describe the active channels.

    Examples
    --------
    Write two seconds of a four-element line array (0.75 m apart, body x forward) and read it:

    >>> import os, tempfile
    >>> import numpy as np
    >>> from arrayproc import Recording, RecordingWriter
    >>> tmp = tempfile.TemporaryDirectory()
    >>> path = os.path.join(tmp.name, "rec.h5")
    >>> positions = np.zeros((4, 3)); positions[:, 0] = -0.75 * np.arange(4)
    >>> with RecordingWriter(path, fs=1000.0, n_channels=4, positions=positions) as w:
    ...     w.append(np.zeros((2000, 4), np.float32))
    >>> with Recording(path) as rec:
    ...     print(rec.n_channels, rec.fs, rec.duration, rec.read(0, 10).shape)
    4 1000.0 2.0 (10, 4)
    >>> tmp.cleanup()
    """

    def __init__(self, path: str | os.PathLike, positions: np.ndarray | None = None,
                 nan: str = "error", sound_speed: float | None = None,
                 require_geometry: bool = True, swmr: bool = False) -> None:
        self.path = Path(path)
        if nan not in ("error", "zero"):
            raise FormatError(f"nan policy must be 'error' or 'zero', not {nan!r}")
        self.nan_policy = nan
        self.n_nonfinite = 0
        self.swmr = bool(swmr)
        self._f = open_h5(self.path, "recording", swmr=self.swmr)
        try:
            self._load(positions, sound_speed, require_geometry)
        except BaseException:
            self._f.close()
            raise

    # -- metadata ------------------------------------------------------------------------
    def _load(self, positions: np.ndarray | None, sound_speed: float | None,
              require_geometry: bool = True) -> None:
        f, p = self._f, self.path
        td = get_object(f, p, "time_data")
        if not isinstance(td, h5py.Dataset):
            raise FormatError(f"{p}: no /time_data dataset (not a recording)")
        if td.ndim != 2:
            raise FormatError(f"{p}: /time_data must be 2-D (samples, channels), has shape "
                              f"{td.shape}")
        if td.dtype.kind not in "fiu":
            raise FormatError(f"{p}: /time_data has non-numeric type {td.dtype}")
        self._td = td
        self.n_samples, n_all = (int(s) for s in td.shape)
        if "sample_freq" not in td.attrs:
            raise FormatError(f"{p}: /time_data has no sample_freq attribute")
        self.fs = attr_number(p, td, "sample_freq")
        if not np.isfinite(self.fs) or self.fs <= 0:
            raise FormatError(f"{p}: sample_freq must be a positive number, got {self.fs}")
        self.units = file_units(td.attrs)  # "Pa" when absent (io/units.py)
        fmt = _attr_str(f.attrs.get("format", ""))
        self.layout = "arrayproc" if fmt == FORMAT else "acoular"
        self.format_version = None
        if fmt == FORMAT:
            v = attr_number(p, f, "format_version", 0)
            if not (np.isfinite(v) and v == int(v) and v >= 0):
                raise FormatError(f"{p}: attribute 'format_version' must be a whole number, "
                                  f"got {v}")
            self.format_version = int(v)
        if self.format_version is not None and self.format_version > FORMAT_VERSION:
            raise FormatError(f"{p}: recording format version {self.format_version} is newer "
                              f"than this arrayproc reads ({FORMAT_VERSION})")
        self.sound_speed = (float(sound_speed) if sound_speed is not None else
                            attr_number(p, f, "sound_speed", DEFAULT_SOUND_SPEED))
        if not (np.isfinite(self.sound_speed) and self.sound_speed > 0):
            raise FormatError(f"{p}: sound_speed must be positive, got {self.sound_speed}")
        self.start_time = _attr_str(f.attrs["start_time"]) if "start_time" in f.attrs else None

        # Geometry of all channels, then the active subset.
        get_object(f, p, "array", h5py.Group)
        file_pos = read_numeric(f, p, "array/positions")
        if positions is not None:
            pos = np.asarray(positions, dtype=float)
            self.geometry_source = "given"
        elif file_pos is not None:
            pos = file_pos
            self.geometry_source = "file"
        elif n_all == 1:
            pos = np.zeros((1, 3))
            self.geometry_source = "single channel"
        elif not require_geometry:
            pos = np.full((n_all, 3), np.nan)
            self.geometry_source = "none"
        else:
            raise FormatError(f"{p}: no /array/positions; give the geometry (e.g. --line N "
                              "SPACING or --geometry FILE)")
        if pos.ndim != 2 or pos.shape[1] != 3:
            raise FormatError(f"{p}: array positions must have shape (n_channels, 3), got "
                              f"{pos.shape}")
        if pos.shape[0] != n_all:
            raise FormatError(f"{p}: array positions have {pos.shape[0]} rows but /time_data "
                              f"has {n_all} channels")
        if self.geometry_source != "none" and not np.all(np.isfinite(pos)):
            raise FormatError(f"{p}: array positions contain NaN or Inf")
        gains = np.ones(n_all)
        g = read_numeric(f, p, "array/gains")
        if g is not None:
            gains = g.reshape(-1)
            if gains.shape != (n_all,) or not np.all(np.isfinite(gains)):
                raise FormatError(f"{p}: /array/gains must be {n_all} finite numbers")
        dead = np.zeros(n_all, dtype=bool)
        d = read_numeric(f, p, "array/dead")
        if d is not None:
            dead = d.astype(bool).reshape(-1)
            if dead.shape != (n_all,):
                raise FormatError(f"{p}: /array/dead must have {n_all} entries")
        if dead.all():
            raise FormatError(f"{p}: every channel is marked dead")
        self.n_channels_file = n_all
        self.channels = np.flatnonzero(~dead)
        self.positions = pos[self.channels]
        self.gains = gains[self.channels]
        self._select = None if self.channels.size == n_all else self.channels
        self._apply_gain = not np.all(self.gains == 1.0)

        self.nav = self._read_nav()
        self._static_pose: Pose | None = None

    def _read_nav(self) -> Nav:
        f, p = self._f, self.path
        if get_object(f, p, "nav", h5py.Group) is None:
            return Nav.static()
        t = read_numeric(f, p, "nav/time", required=True).reshape(-1)
        pos = read_numeric(f, p, "nav/position", required=True)
        hd = read_numeric(f, p, "nav/heading", required=True).reshape(-1)
        dp = read_numeric(f, p, "nav/depth")
        dp = dp.reshape(-1) if dp is not None else None
        if t.size == 0:
            raise FormatError(f"{p}: /nav/time is empty")
        if np.any(np.diff(t) <= 0):
            raise FormatError(f"{p}: /nav/time is not strictly increasing")
        if pos.shape != (t.size, 2):
            raise FormatError(f"{p}: /nav/position must have shape ({t.size}, 2), got "
                              f"{pos.shape}")
        if hd.shape != t.shape or (dp is not None and dp.shape != t.shape):
            raise FormatError(f"{p}: /nav/heading and /nav/depth must match /nav/time")
        arrays = [t, pos, hd] + ([dp] if dp is not None else [])
        if not all(np.all(np.isfinite(a)) for a in arrays):
            raise FormatError(f"{p}: /nav contains NaN or Inf")
        return Nav(t, pos, hd, dp)

    @property
    def n_channels(self) -> int:
        """Number of active (not dead) channels."""
        return int(self.channels.size)

    @property
    def duration(self) -> float:
        """Length of the recording, s."""
        return self.n_samples / self.fs

    def has(self, name: str) -> bool:
        """Whether the file holds an object at ``name`` (e.g. ``"truth"``); a dangling link
        raises FormatError."""
        try:
            return get_object(self._f, self.path, name) is not None
        except FormatError:
            raise
        except (KeyError, OSError, ValueError, TypeError):
            return False

    def read_group(self, name: str) -> dict[str, Any]:
        """Every dataset below ``name`` as numpy arrays (nested dicts), attrs under ``"attrs"``.

        Raises FormatError when ``name`` is not a group or holds a dangling link.
        """
        def walk(g: h5py.Group, where: str) -> dict[str, Any]:
            out: dict[str, Any] = {"attrs": dict(g.attrs)}
            for k in g:
                v = get_object(self._f, self.path, f"{where}/{k}")
                out[k] = walk(v, f"{where}/{k}") if isinstance(v, h5py.Group) else v[()]
            return out
        g = get_object(self._f, self.path, name, h5py.Group)
        if g is None:
            raise FormatError(f"{self.path}: no /{name} group")
        return walk(g, name)

    def active(self) -> ActivePings | None:
        """The ``/active`` ping schedule and replicas (docs/formats.md), or None without it.

        ``/active/pings/waveform`` may index the sorted waveform names or hold the names.
        """
        if "active" not in self._f:
            return None
        g, p = self._f["active"], self.path
        try:
            names = sorted(g["waveforms"].keys())
            t = np.asarray(g["pings/time"][()], float).reshape(-1)
            wv = np.asarray(g["pings/waveform"][()]).reshape(-1)
        except KeyError as e:
            raise FormatError(f"{p}: /active needs waveforms/, pings/time and pings/waveform "
                              f"({e})") from None
        if wv.shape != t.shape or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
            raise FormatError(f"{p}: /active/pings/time must increase and match "
                              "/active/pings/waveform")
        if wv.dtype.kind in "iu":
            if wv.size and (wv.min() < 0 or wv.max() >= len(names)):
                raise FormatError(f"{p}: /active/pings/waveform indexes a missing waveform")
            which = [names[int(i)] for i in wv]
        else:
            which = [_attr_str(v) for v in wv]
            bad = [n for n in which if n not in names]
            if bad:
                raise FormatError(f"{p}: /active/pings/waveform names {bad[0]!r}, not in "
                                  "/active/waveforms")
        reps = {}
        for n in names:
            d = g["waveforms"][n]
            a = d.attrs
            try:
                reps[n] = Replica(np.asarray(d[()], float).reshape(-1), self.fs,
                                  _attr_str(a["kind"]), float(a["fc"]), float(a["bandwidth"]),
                                  float(a["duration"]), int(a.get("bits", 0)))
            except KeyError as e:
                raise FormatError(f"{p}: /active/waveforms/{n} lacks attribute {e}") from None
        proj = np.asarray(g.attrs.get("projector", np.zeros(3)), float).reshape(-1)
        if proj.shape != (3,):
            raise FormatError(f"{p}: /active attribute projector must hold 3 numbers")
        return ActivePings(t, which, reps, proj)

    # -- data ----------------------------------------------------------------------------
    def read(self, start: int = 0, stop: int | None = None,
             dtype: np.dtype | type = np.float32) -> np.ndarray:
        """Samples [start, stop) of the active channels, gains applied, shape (n, n_channels)."""
        stop = self.n_samples if stop is None else min(int(stop), self.n_samples)
        start = max(0, int(start))
        if stop <= start:
            return np.zeros((0, self.n_channels), dtype=dtype)
        raw = self._td[start:stop]
        if self._select is not None:
            raw = raw[:, self._select]
        x = np.asarray(raw, dtype=dtype)
        if self._apply_gain:
            x *= self.gains.astype(dtype)
        if not np.isfinite(x).all():
            bad = ~np.isfinite(x)
            if self.nan_policy == "error":
                i, ch = np.argwhere(bad)[0]
                raise FormatError(f"{self.path}: NaN or Inf sample at sample {start + i}, "
                                  f"channel {self.channels[ch]} (use --nan zero to zero them)")
            self.n_nonfinite += int(bad.sum())
            x[bad] = 0.0
        return x

    def refresh(self) -> int:
        """Samples now in the file: re-reads ``/time_data``'s length, which a writer in SWMR
        mode grows (a recording opened with ``swmr=True``; otherwise the length at open), and
        ``/nav`` when the writer grew it too (all its datasets to one new length)."""
        if self.swmr:
            self._td.refresh()
            self.n_samples = int(self._td.shape[0])
            self._refresh_nav()
        return self.n_samples

    def _refresh_nav(self) -> None:
        g = self._f.get("nav")
        if not isinstance(g, h5py.Group):
            return
        sets = [g[k] for k in ("time", "position", "heading", "depth")
                if isinstance(g.get(k), h5py.Dataset)]
        for d in sets:
            d.refresh()
        lengths = {int(d.shape[0]) for d in sets}
        if len(lengths) == 1 and lengths.pop() != self.nav.time.size:
            self.nav = self._read_nav()
            self._static_pose = None

    def nav_end(self) -> float:
        """Time of the last ``/nav`` row (s); ``inf`` for a static array (one row or none)."""
        t = self.nav.time
        return float(t[-1]) if t.size > 1 else float("inf")

    def pose(self, t: float) -> Pose:
        """The array's pose at time t (s): reference point, heading, element world positions."""
        return self.poses(np.array([t]))[0]

    def poses(self, t: np.ndarray) -> list[Pose]:
        """Poses at several times at once (one interpolation pass over the nav track)."""
        if self.nav.time.size == 1:  # static array: one pose serves every block
            if self._static_pose is None:
                pos, hd, dp, spd = self.nav.at(0.0)
                self._static_pose = Pose(pos[0], float(hd[0]), float(dp[0]), 0.0, body_to_world(
                    self.positions, pos[0], float(hd[0]), float(dp[0])))
            return [self._static_pose] * len(t)
        pos, hd, dp, spd = self.nav.at(t)
        return [Pose(pos[i], float(hd[i]), float(dp[i]), float(spd[i]),
                     body_to_world(self.positions, pos[i], float(hd[i]), float(dp[i])))
                for i in range(len(t))]

    # -- lifetime ------------------------------------------------------------------------
    def close(self) -> None:
        self._f.close()

    def __enter__(self) -> Recording:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class RecordingWriter(AtomicH5Writer):
    """Streams a recording to disk: ``append`` chunks of samples, then ``close``.

    The file is written under a temporary name in the target directory and renamed on a
    successful close; on an exception inside a ``with`` block it is removed, so a reader never
    sees a half-written recording. ``live=True`` (a recorder) writes the file in place in SWMR
    mode instead: :meth:`flush` after appends, and ``arrayproc process --follow`` processes
    it while it grows.
    """

    def __init__(self, path: str | os.PathLike, fs: float, n_channels: int,
                 positions: np.ndarray | None = None, sound_speed: float = DEFAULT_SOUND_SPEED,
                 start_time: str | None = None, dtype: np.dtype | type = np.float32,
                 units: str = "Pa", chunk_samples: int | None = None,
                 attrs: dict[str, Any] | None = None, live: bool = False) -> None:
        super().__init__(path, fs, n_channels, positions, sound_speed, start_time, dtype,
                         units, chunk_samples, attrs, live=live)

    def _start(self, fs: float, n_channels: int, positions: np.ndarray | None,
               sound_speed: float, start_time: str | None, dtype: np.dtype | type, units: str,
               chunk_samples: int | None, attrs: dict[str, Any] | None) -> None:
        if not (np.isfinite(fs) and fs > 0):
            raise FormatError(f"{self.path}: sample rate must be a finite number > 0 Hz, "
                              f"got {fs}")
        if not (np.isfinite(sound_speed) and sound_speed > 0):
            raise FormatError(f"{self.path}: sound speed must be a finite number > 0 m/s, "
                              f"got {sound_speed}")
        if positions is not None and not np.all(np.isfinite(np.asarray(positions, float))):
            raise FormatError(f"{self.path}: array positions contain NaN or Inf")
        self._f.attrs["format"] = FORMAT
        self._f.attrs["format_version"] = FORMAT_VERSION
        self._f.attrs["sound_speed"] = float(sound_speed)
        if start_time is not None:
            self._f.attrs["start_time"] = start_time
        for k, v in (attrs or {}).items():
            self._f.attrs[k] = v
        if chunk_samples is None:  # about 1 MiB chunks, contiguous in time
            chunk_samples = max(256, (1 << 20) // (np.dtype(dtype).itemsize * n_channels))
        self._td = self._f.create_dataset(
            "time_data", shape=(0, n_channels), maxshape=(None, n_channels), dtype=dtype,
            chunks=(int(chunk_samples), n_channels))
        self._td.attrs["sample_freq"] = float(fs)
        self._td.attrs["units"] = units
        if positions is not None:
            self._f.create_dataset("array/positions", data=np.asarray(positions, float))
        self.n_samples = 0

    def append(self, data: np.ndarray) -> None:
        """Append samples (n, n_channels)."""
        check_stop()
        n = data.shape[0]
        self._td.resize(self.n_samples + n, axis=0)
        self._td[self.n_samples:self.n_samples + n] = data
        self.n_samples += n

    def set_nav(self, time: np.ndarray, position: np.ndarray, heading: np.ndarray,
                depth: np.ndarray | None = None) -> None:
        """Write ``/nav`` (time s, position (n,2) m, heading deg true, optional depth m)."""
        g = self._f.require_group("nav")
        g.create_dataset("time", data=np.asarray(time, float))
        g.create_dataset("position", data=np.asarray(position, float))
        g.create_dataset("heading", data=np.asarray(heading, float))
        if depth is not None:
            g.create_dataset("depth", data=np.asarray(depth, float))

    def set_array(self, gains: np.ndarray | None = None, dead: np.ndarray | None = None) -> None:
        """Write optional ``/array/gains`` and ``/array/dead``."""
        if gains is not None:
            self._f.create_dataset("array/gains", data=np.asarray(gains, float))
        if dead is not None:
            self._f.create_dataset("array/dead", data=np.asarray(dead, bool))

    def set_active(self, time: np.ndarray, waveform: np.ndarray,
                   waveforms: dict[str, tuple[np.ndarray, dict[str, Any]]],
                   projector: np.ndarray) -> None:
        """Write ``/active`` (docs/formats.md): ping times (s), each ping's index into the
        sorted waveform names, the replicas ``{name: (samples at fs, attrs)}`` with attrs
        ``kind``, ``fc``, ``bandwidth``, ``duration`` (and ``bits``), the projector (m)."""
        g = self._f.require_group("active")
        g.attrs["projector"] = np.asarray(projector, float).reshape(3)
        for name, (x, attrs) in waveforms.items():
            d = g.create_dataset(f"waveforms/{name}", data=np.asarray(x, float))
            for k, v in attrs.items():
                d.attrs[k] = v
        g.create_dataset("pings/time", data=np.asarray(time, float))
        g.create_dataset("pings/waveform", data=np.asarray(waveform, np.int64))

    def write_group(self, name: str, datasets: dict[str, Any],
                    attrs: dict[str, Any] | None = None) -> None:
        """Write a group of datasets (nested dicts make subgroups), e.g. ``truth/sources/a``."""
        check_stop()
        for part in name.split("/"):
            if part in ("", ".", ".."):
                raise FormatError(f"{self.path}: group name {name!r} has an empty, '.' or '..' "
                                  "part")
        for k in datasets:
            if not isinstance(k, str) or not k or "/" in k or k in (".", ".."):
                raise FormatError(f"{self.path}: {name}: dataset name {k!r} is not a plain "
                                  "name (no '/', not empty, '.' or '..')")
        g = self._f.require_group(name)
        for k, v in (attrs or {}).items():
            g.attrs[k] = v
        for k, v in datasets.items():
            if isinstance(v, dict):
                self.write_group(f"{name}/{k}", v)
            else:
                g.create_dataset(k, data=v)
