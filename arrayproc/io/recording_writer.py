"""Writing recording files: samples streamed in chunks, navigation, array calibration, the
active ping schedule and truth groups, built under a temporary name and renamed when complete
(:class:`arrayproc.io.atomic.AtomicH5Writer`). The layout's name and version live here; the
reader is :class:`arrayproc.io.recording.Recording`.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np

from arrayproc.errors import FormatError
from arrayproc.io.atomic import AtomicH5Writer, check_free_space, check_stop

FORMAT = "arrayproc.recording"
FORMAT_VERSION = 1
DEFAULT_SOUND_SPEED = 1500.0


class RecordingWriter(AtomicH5Writer):
    """Streams a recording to disk: ``append`` chunks of samples, then ``close``.

    The file is written under a temporary name in the target directory and renamed on a
    successful close; on an exception inside a ``with`` block it is removed, so a reader never
    sees a half-written recording. ``live=True`` (a recorder) writes the file in place in SWMR
    mode instead: :meth:`flush` after appends, and ``arrayproc process --follow`` processes
    it while it grows. ``expected_samples``, when the length is known (``simulate``,
    ``import``), refuses at once an output its folder has no room for
    (:func:`arrayproc.io.atomic.check_free_space`).
    """

    def __init__(self, path: str | os.PathLike, fs: float, n_channels: int,
                 positions: np.ndarray | None = None, sound_speed: float = DEFAULT_SOUND_SPEED,
                 start_time: str | None = None, dtype: np.dtype | type = np.float32,
                 units: str = "Pa", chunk_samples: int | None = None,
                 attrs: dict[str, Any] | None = None, live: bool = False,
                 expected_samples: int | None = None) -> None:
        super().__init__(path, fs, n_channels, positions, sound_speed, start_time, dtype,
                         units, chunk_samples, attrs, expected_samples, live=live)

    def _start(self, fs: float, n_channels: int, positions: np.ndarray | None,
               sound_speed: float, start_time: str | None, dtype: np.dtype | type, units: str,
               chunk_samples: int | None, attrs: dict[str, Any] | None,
               expected_samples: int | None = None) -> None:
        if expected_samples is not None:  # the size is known: refuse before writing
            check_free_space(self.path, float(expected_samples) * int(n_channels)
                             * np.dtype(dtype).itemsize)
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
            chunks=(int(chunk_samples), n_channels), fletcher32=True)  # damage found on read
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
        self.check()  # a failed write stops here (disk full, I/O error)

    def set_calibration(self, text: str) -> None:
        """The ``/time_data`` attribute ``calibration``: how the samples were turned into
        their unit (e.g. ``sensitivity -170 dB re 1 V/µPa, gain 20 dB, full scale 1 V``)."""
        self._td.attrs["calibration"] = str(text)

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
