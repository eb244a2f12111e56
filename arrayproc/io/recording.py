"""Recording files (DESIGN section 3): a streaming reader into blocks and a streaming writer.

The reader pulls ``/time_data`` by HDF5 hyperslabs of a fixed size (a few MB), so memory is
bounded by the slab and block sizes, never by the file length. Files in acoular's layout (only
``/time_data`` with ``sample_freq``) open too, with the geometry given by the caller.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from arrayproc.chain.block import Block, Pose
from arrayproc.chain.domains import Domain, TimeMeta
from arrayproc.errors import FormatError
from arrayproc.geo.nav import Nav
from arrayproc.io.atomic import AtomicH5Writer
from arrayproc.io.geometry import body_to_world

FORMAT = "arrayproc.recording"
FORMAT_VERSION = 1
DEFAULT_SOUND_SPEED = 1500.0
SLAB_BYTES = 8 << 20  # hyperslab size the reader pulls at once


def open_h5(path: str | os.PathLike, what: str = "file") -> h5py.File:
    """Open an HDF5 file read-only, turning every failure into one clear FormatError."""
    path = Path(path)
    if not path.exists():
        raise FormatError(f"{path}: no such {what}")
    if path.is_dir():
        raise FormatError(f"{path}: is a directory, not an HDF5 {what}")
    try:
        if not h5py.is_hdf5(path):
            raise FormatError(f"{path}: not an HDF5 file")
        return h5py.File(path, "r")
    except FormatError:
        raise
    except OSError as e:
        raise FormatError(f"{path}: cannot open HDF5 file (truncated or corrupt?): {e}") from None


def _attr_str(v: Any) -> str:
    return v.decode() if isinstance(v, bytes) else str(v)


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
    """

    def __init__(self, path: str | os.PathLike, positions: np.ndarray | None = None,
                 nan: str = "error", sound_speed: float | None = None) -> None:
        self.path = Path(path)
        if nan not in ("error", "zero"):
            raise FormatError(f"nan policy must be 'error' or 'zero', not {nan!r}")
        self.nan_policy = nan
        self.n_nonfinite = 0
        self._f = open_h5(self.path, "recording")
        try:
            self._load(positions, sound_speed)
        except Exception:
            self._f.close()
            raise

    # -- metadata ------------------------------------------------------------------------
    def _load(self, positions: np.ndarray | None, sound_speed: float | None) -> None:
        f, p = self._f, self.path
        if "time_data" not in f or not isinstance(f["time_data"], h5py.Dataset):
            raise FormatError(f"{p}: no /time_data dataset (not a recording)")
        td = f["time_data"]
        if td.ndim != 2:
            raise FormatError(f"{p}: /time_data must be 2-D (samples, channels), has shape "
                              f"{td.shape}")
        if td.dtype.kind not in "fiu":
            raise FormatError(f"{p}: /time_data has non-numeric type {td.dtype}")
        self._td = td
        self.n_samples, n_all = (int(s) for s in td.shape)
        if "sample_freq" not in td.attrs:
            raise FormatError(f"{p}: /time_data has no sample_freq attribute")
        self.fs = float(np.asarray(td.attrs["sample_freq"]).reshape(-1)[0])
        if not np.isfinite(self.fs) or self.fs <= 0:
            raise FormatError(f"{p}: sample_freq must be a positive number, got {self.fs}")
        self.units = _attr_str(td.attrs.get("units", "Pa"))
        fmt = _attr_str(f.attrs.get("format", ""))
        self.layout = "arrayproc" if fmt == FORMAT else "acoular"
        self.format_version = int(f.attrs.get("format_version", 0)) if fmt == FORMAT else None
        if self.format_version is not None and self.format_version > FORMAT_VERSION:
            raise FormatError(f"{p}: recording format version {self.format_version} is newer "
                              f"than this arrayproc reads ({FORMAT_VERSION})")
        c = sound_speed if sound_speed is not None else f.attrs.get("sound_speed",
                                                                    DEFAULT_SOUND_SPEED)
        self.sound_speed = float(c)
        if not (np.isfinite(self.sound_speed) and self.sound_speed > 0):
            raise FormatError(f"{p}: sound_speed must be positive, got {self.sound_speed}")
        self.start_time = _attr_str(f.attrs["start_time"]) if "start_time" in f.attrs else None

        # Geometry of all channels, then the active subset.
        if positions is not None:
            pos = np.asarray(positions, dtype=float)
            self.geometry_source = "given"
        elif "array/positions" in f:
            pos = np.asarray(f["array/positions"][()], dtype=float)
            self.geometry_source = "file"
        elif n_all == 1:
            pos = np.zeros((1, 3))
            self.geometry_source = "single channel"
        else:
            raise FormatError(f"{p}: no /array/positions; give the geometry (e.g. --line N "
                              "SPACING or --geometry FILE)")
        if pos.ndim != 2 or pos.shape[1] != 3:
            raise FormatError(f"{p}: array positions must have shape (n_channels, 3), got "
                              f"{pos.shape}")
        if pos.shape[0] != n_all:
            raise FormatError(f"{p}: array positions have {pos.shape[0]} rows but /time_data "
                              f"has {n_all} channels")
        if not np.all(np.isfinite(pos)):
            raise FormatError(f"{p}: array positions contain NaN or Inf")
        gains = np.ones(n_all)
        if "array/gains" in f:
            gains = np.asarray(f["array/gains"][()], dtype=float).reshape(-1)
            if gains.shape != (n_all,) or not np.all(np.isfinite(gains)):
                raise FormatError(f"{p}: /array/gains must be {n_all} finite numbers")
        dead = np.zeros(n_all, dtype=bool)
        if "array/dead" in f:
            dead = np.asarray(f["array/dead"][()], dtype=bool).reshape(-1)
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
        if "nav" not in f:
            return Nav.static()
        g = f["nav"]
        for k in ("time", "position", "heading"):
            if k not in g:
                raise FormatError(f"{p}: /nav/{k} is missing")
        t = np.asarray(g["time"][()], dtype=float).reshape(-1)
        pos = np.asarray(g["position"][()], dtype=float)
        hd = np.asarray(g["heading"][()], dtype=float).reshape(-1)
        dp = np.asarray(g["depth"][()], dtype=float).reshape(-1) if "depth" in g else None
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
        """Whether the file holds an object at ``name`` (e.g. ``"truth"``)."""
        return name in self._f

    def read_group(self, name: str) -> dict[str, Any]:
        """Every dataset below ``name`` as numpy arrays (nested dicts), attrs under ``"attrs"``."""
        def walk(g: h5py.Group) -> dict[str, Any]:
            out: dict[str, Any] = {"attrs": dict(g.attrs)}
            for k, v in g.items():
                out[k] = walk(v) if isinstance(v, h5py.Group) else v[()]
            return out
        return walk(self._f[name])

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

    def n_blocks(self, nfft: int, hop: int, start: int = 0, stop: int | None = None) -> int:
        """How many blocks :meth:`blocks` yields for these parameters."""
        stop = self.n_samples if stop is None else min(int(stop), self.n_samples)
        n = stop - start
        if n <= 0:
            return 0
        return 1 + max(0, -(-(n - nfft) // hop))

    def blocks(self, nfft: int, hop: int | None = None, start: int = 0, stop: int | None = None,
               dtype: np.dtype | type = np.float32, first_index: int = 0) -> Iterator[Block]:
        """Time-domain blocks of ``nfft`` samples every ``hop`` samples over [start, stop).

        Block k covers samples [start + k·hop, start + k·hop + nfft). The last block is the
        first one that reaches ``stop``; samples past ``stop`` are zeros and the block's
        ``meta["n_valid"]`` says how many are real. So the hop-long heads of all blocks but the
        last, followed by the last block's valid samples, tile [start, stop) exactly. Each
        block carries the pose at its centre time.
        """
        hop = nfft if hop is None else int(hop)
        nfft = int(nfft)
        if nfft < 1 or hop < 1:
            raise FormatError(f"block size and hop must be >= 1 (got {nfft}, {hop})")
        stop = self.n_samples if stop is None else min(int(stop), self.n_samples)
        nb = self.n_blocks(nfft, hop, start, stop)
        itemsize = np.dtype(dtype).itemsize * max(1, self.n_channels_file)
        per_slab = max(1, (SLAB_BYTES // itemsize - nfft) // hop + 1)  # blocks per slab
        k = 0
        while k < nb:
            kk = min(nb, k + per_slab)
            a = start + k * hop
            b = min(stop, start + (kk - 1) * hop + nfft)
            slab = self.read(a, b, dtype)
            poses = self.poses((start + np.arange(k, kk) * hop + 0.5 * nfft) / self.fs)
            for j in range(k, kk):
                s = start + j * hop
                seg = slab[s - a: s - a + nfft]
                n_valid = seg.shape[0]
                if n_valid < nfft:
                    seg = np.concatenate(
                        [seg, np.zeros((nfft - n_valid, self.n_channels), dtype=dtype)])
                t0 = s / self.fs
                yield Block(seg, Domain.TIME, t0, nfft / self.fs, self.fs,
                            self.positions, poses[j - k],
                            index=first_index + j, meta=TimeMeta(s, n_valid))
            k = kk

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
    sees a half-written recording.
    """

    def __init__(self, path: str | os.PathLike, fs: float, n_channels: int,
                 positions: np.ndarray | None = None, sound_speed: float = DEFAULT_SOUND_SPEED,
                 start_time: str | None = None, dtype: np.dtype | type = np.float32,
                 units: str = "Pa", chunk_samples: int | None = None,
                 attrs: dict[str, Any] | None = None) -> None:
        super().__init__(path)
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

    def write_group(self, name: str, datasets: dict[str, Any],
                    attrs: dict[str, Any] | None = None) -> None:
        """Write a group of datasets (nested dicts make subgroups), e.g. ``truth/sources/a``."""
        g = self._f.require_group(name)
        for k, v in (attrs or {}).items():
            g.attrs[k] = v
        for k, v in datasets.items():
            if isinstance(v, dict):
                self.write_group(f"{name}/{k}", v)
            else:
                g.create_dataset(k, data=v)
