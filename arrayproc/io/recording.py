"""Recording files (docs/formats.md): a streaming reader into blocks.

The reader pulls ``/time_data`` by HDF5 hyperslabs of a fixed size (a few MB), so memory is
bounded by the slab and block sizes, never by the file length. Files in acoular's layout (only
``/time_data`` with ``sample_freq``) open too, with the geometry given by the caller.

The writer (:mod:`arrayproc.io.recording_writer`), the ``/active`` reader
(:mod:`arrayproc.io.pings`) and the defensive HDF5 helpers (:mod:`arrayproc.io.h5`) live in
their own modules; their names are importable from here too.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from arrayproc.errors import FormatError
from arrayproc.geo.nav import Nav
from arrayproc.geo.pose import Pose
from arrayproc.io.geometry import body_to_world
from arrayproc.io.h5 import (
    _attr_str,
    attr_number,
    attr_str,
    damage_reason,
    first_bad_row,
    get_object,
    open_h5,
    read_numeric,
    stored_rows,
)
from arrayproc.io.pings import ActivePings, Replica, read_active
from arrayproc.io.recording_writer import (
    DEFAULT_SOUND_SPEED,
    FORMAT,
    FORMAT_VERSION,
    RecordingWriter,
)
from arrayproc.io.units import file_units

__all__ = ["DEFAULT_SOUND_SPEED", "FORMAT", "FORMAT_VERSION", "ActivePings", "Recording",
           "RecordingWriter", "Replica", "_attr_str", "attr_number", "attr_str", "get_object",
           "open_h5", "read_numeric"]


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
        # rows a writer declared but never wrote (it died): reads stop there (self.read)
        self.damaged_from = None if self.swmr else stored_rows(td)
        if "sample_freq" not in td.attrs:
            raise FormatError(f"{p}: /time_data has no sample_freq attribute")
        self.fs = attr_number(p, td, "sample_freq")
        if not np.isfinite(self.fs) or self.fs <= 0:
            raise FormatError(f"{p}: sample_freq must be a positive number, got {self.fs}")
        self.units = file_units(td.attrs)  # "Pa" when absent (io/units.py)
        fmt = attr_str(f.attrs.get("format", ""))
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
        self.start_time = attr_str(f.attrs["start_time"]) if "start_time" in f.attrs else None

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
        if self.swmr:
            t, pos, hd, dp = written_nav_rows(t, pos, hd, dp)
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
        """The ``/active`` ping schedule and replicas (docs/formats.md), or None without it
        (:func:`arrayproc.io.pings.read_active`)."""
        return read_active(self._f, self.path, self.fs)

    # -- data ----------------------------------------------------------------------------
    def read(self, start: int = 0, stop: int | None = None,
             dtype: np.dtype | type = np.float32) -> np.ndarray:
        """Samples [start, stop) of the active channels, gains applied, shape (n, n_channels)."""
        stop = self.n_samples if stop is None else min(int(stop), self.n_samples)
        start = max(0, int(start))
        if stop <= start:
            return np.zeros((0, self.n_channels), dtype=dtype)
        if self.damaged_from is not None and stop > self.damaged_from:
            k = self.damaged_from
            raise FormatError(f"{self.path}: /time_data holds fewer samples than it declares: "
                              f"stored up to t = {k / self.fs:.3f} s (sample {k}) of "
                              f"{self.n_samples / self.fs:.3f} s declared (its writer stopped "
                              "before writing the rest); the samples before it read")
        try:
            raw = self._td[start:stop]
        except (OSError, ValueError, RuntimeError) as e:
            if self.swmr:
                raise
            bad, text = first_bad_row(self._td, start, stop)
            self._damaged(bad, damage_reason(text or str(e)))
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

    def _damaged(self, row: int, why: str) -> None:
        """Stop a read at damaged samples, naming the time at which the damage starts."""
        raise FormatError(f"{self.path}: /time_data is damaged from t = {row / self.fs:.3f} s "
                          f"(sample {row}): {why}; the samples before it read")

    def refresh(self) -> int:
        """Samples now in the file: re-reads ``/time_data``'s length, which a writer in SWMR
        mode grows (a recording opened with ``swmr=True``; otherwise the length at open), and
        ``/nav`` when the writer grew it too (:func:`written_nav_rows`: the rows every one of
        its datasets holds)."""
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
        if min(int(d.shape[0]) for d in sets) != self.nav.time.size:
            nav = self._read_nav()
            if nav.time.size != self.nav.time.size:
                self.nav = nav
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


def written_nav_rows(t: np.ndarray, pos: np.ndarray, hd: np.ndarray,
                     dp: np.ndarray | None) -> tuple[np.ndarray, ...]:
    """The ``/nav`` rows a writer growing the file in SWMR mode has finished.

    A live writer grows ``time``, ``position``, ``heading`` (and ``depth``) one after another,
    then writes the new row, so a reader can open the file between two of those steps. Only
    the rows every dataset holds count, and a trailing row whose time is not yet written (the
    fill value: not after the row before it), or whose other values are not finite (a NaN
    fill), is left for the next refresh; a writer that writes ``time`` last is never read half
    way. Rows before it are checked as in a finished file.
    """
    m = min(t.shape[0], pos.shape[0], hd.shape[0], dp.shape[0] if dp is not None else t.size)

    def written(i: int) -> bool:
        rest = [pos[i], hd[i]] + ([dp[i]] if dp is not None else [])
        return bool(t[i] > t[i - 1] and all(np.all(np.isfinite(v)) for v in rest))
    while m > 1 and not written(m - 1):
        m -= 1
    return t[:m], pos[:m], hd[:m], (dp[:m] if dp is not None else None)
