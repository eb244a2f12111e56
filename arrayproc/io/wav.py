"""Field recordings in WAV files → the recording format, streamed in chunks.

One multichannel WAV, or one mono WAV per hydrophone (channel order = the natural order of the
file names, :func:`channel_order`). PCM 8, 16,
24 and 32 bit and IEEE float 32/64 bit; WAVE_FORMAT_EXTENSIBLE headers too. Samples are stored
as fractions of full scale (``units = "FS"``) unless a scale to pascals is given.
"""

from __future__ import annotations

import os
import re
import struct
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from arrayproc.errors import FormatError
from arrayproc.io.calibration import Calibration
from arrayproc.io.recording import RecordingWriter

_PCM, _FLOAT, _EXTENSIBLE = 1, 3, 0xFFFE


@dataclass
class WavInfo:
    """What a WAV header says: sample rate, channels, sample format, where the data lies."""

    path: Path
    fs: int
    n_channels: int
    bits: int
    is_float: bool
    data_offset: int
    n_frames: int
    #: Frames the header declares but the file does not hold (a truncated file), else 0.
    missing_frames: int = 0

    @property
    def frame_bytes(self) -> int:
        return self.n_channels * self.bits // 8

    @property
    def kind(self) -> str:
        return f"{self.bits}-bit {'float' if self.is_float else 'PCM'}"


def read_wav_info(path: str | os.PathLike) -> WavInfo:
    """Parse the RIFF header of a WAV file (no sample data is read)."""
    path = Path(path)
    try:
        f = open(path, "rb")
    except FileNotFoundError:
        raise FormatError(f"{path}: no such WAV file") from None
    except OSError as e:
        raise FormatError(f"{path}: cannot open ({e.strerror})") from None
    with f:
        head = f.read(12)
        if len(head) < 12 or head[:4] not in (b"RIFF", b"RF64") or head[8:12] != b"WAVE":
            raise FormatError(f"{path}: not a WAV file (no RIFF/WAVE header)")
        fmt = None
        size_total = os.fstat(f.fileno()).st_size
        while True:
            ch = f.read(8)
            if len(ch) < 8:
                raise FormatError(f"{path}: WAV file has no data chunk")
            cid, size = ch[:4], struct.unpack("<I", ch[4:])[0]
            if cid == b"fmt ":
                body = f.read(size)
                if len(body) < 16:
                    raise FormatError(f"{path}: truncated fmt chunk")
                tag, nch, fs, _, _, bits = struct.unpack("<HHIIHH", body[:16])
                if tag == _EXTENSIBLE and len(body) >= 26:
                    tag = struct.unpack("<H", body[24:26])[0]
                fmt = (tag, nch, fs, bits)
                if size % 2:
                    f.seek(1, 1)
            elif cid == b"data":
                if fmt is None:
                    raise FormatError(f"{path}: data chunk before fmt chunk")
                offset = f.tell()
                tag, nch, fs, bits = fmt
                if tag not in (_PCM, _FLOAT):
                    raise FormatError(f"{path}: unsupported WAV sample format tag {tag}")
                if tag == _PCM and bits not in (8, 16, 24, 32):
                    raise FormatError(f"{path}: unsupported PCM bit depth {bits}")
                if tag == _FLOAT and bits not in (32, 64):
                    raise FormatError(f"{path}: unsupported float bit depth {bits}")
                if nch < 1 or fs < 1:
                    raise FormatError(f"{path}: WAV header has {nch} channels at {fs} Hz")
                frame = nch * bits // 8
                missing = 0
                if size == 0xFFFFFFFF:  # RF64 / streamed: the data runs to the end
                    size = size_total - offset
                elif offset + size > size_total:  # truncated: keep what is there, say so
                    missing = -(-(offset + size - size_total) // frame)
                    size = size_total - offset
                return WavInfo(path, fs, nch, bits, tag == _FLOAT, offset, size // frame,
                               missing)
            else:
                f.seek(size + (size % 2), 1)


def read_wav_frames(info: WavInfo, start: int, count: int) -> np.ndarray:
    """Frames [start, start + count) as float64 fractions of full scale, shape (count, n_ch)."""
    count = max(0, min(count, info.n_frames - start))
    with open(info.path, "rb") as f:
        f.seek(info.data_offset + start * info.frame_bytes)
        raw = f.read(count * info.frame_bytes)
    count = len(raw) // info.frame_bytes
    raw = raw[: count * info.frame_bytes]
    b = info.bits
    if info.is_float:
        x = np.frombuffer(raw, dtype="<f4" if b == 32 else "<f8").astype(np.float64)
    elif b == 8:  # unsigned, offset 128
        x = (np.frombuffer(raw, dtype=np.uint8).astype(np.float64) - 128.0) / 128.0
    elif b == 16:
        x = np.frombuffer(raw, dtype="<i2") / 32768.0
    elif b == 24:
        u = np.frombuffer(raw, dtype=np.uint8).reshape(-1, 3).astype(np.int32)
        v = u[:, 0] | (u[:, 1] << 8) | (u[:, 2] << 16)
        v = np.where(v >= 1 << 23, v - (1 << 24), v)
        x = v / float(1 << 23)
    else:
        x = np.frombuffer(raw, dtype="<i4") / 2147483648.0
    return x.reshape(count, info.n_channels)


#: File name endings read by this module's WAV reader; the rest go to libsndfile.
WAV_SUFFIXES = (".wav", ".wave")


def audio_info(path: str | os.PathLike) -> Any:
    """The header of any audio file: WAV by :func:`read_wav_info`, every other format by
    libsndfile (:func:`arrayproc.io.audio.soundfile_info`)."""
    if Path(path).suffix.lower() in WAV_SUFFIXES:
        return read_wav_info(path)
    from arrayproc.io.audio import soundfile_info
    return soundfile_info(path)


def read_frames(info: Any, start: int, count: int) -> np.ndarray:
    """Frames [start, start + count) of any audio file as float64 fractions of full scale."""
    if isinstance(info, WavInfo):
        return read_wav_frames(info, start, count)
    from arrayproc.io.audio import soundfile_frames
    return soundfile_frames(info, start, count)


def _name_key(name: str) -> list[tuple[int, int, str]]:
    """Natural sort key of a file name: text runs compared as text, digit runs as numbers."""
    return [(1, int(t), t) if t.isdigit() else (0, 0, t) for t in re.split(r"(\d+)", name)]


def _numbers_decide(a: str, b: str) -> bool:
    """Whether the first difference between two names is a number of different value (so
    ``hyd2`` < ``hyd10`` is decided; ``port`` / ``stbd`` or ``h01`` / ``h1`` are not)."""
    for x, y in zip(_name_key(a), _name_key(b)):
        if x != y:
            return x[0] == y[0] == 1 and x[1] != y[1]
    return False


def channel_order(paths: Sequence[str | os.PathLike]) -> tuple[list, str | None]:
    """The hydrophone order of mono WAV files: natural order of their names.

    A shell glob gives ``hyd1, hyd10, hyd11, …, hyd2``, which would scramble the channels
    against the geometry; the files are sorted by the numbers in their names instead
    (``hyd1, hyd2, …, hyd10``). When some neighbours in that order differ by text rather than
    by a number (``port.wav stbd.wav``), nothing decides the order: the given order is kept if
    it is already the sorted one, else refused.

    Parameters
    ----------
    paths : list of path-like
        The files, in the order given.

    Returns
    -------
    (list, str or None)
        The files in channel order, and a one-line notice when that differs from the given
        order (else None).

    Raises
    ------
    FormatError
        The order is ambiguous: names that sort differently from the given order with no
        number to decide between them, or two names with the same number (``h01``, ``h1``).
    """
    names = [Path(p).name for p in paths]
    order = sorted(range(len(paths)), key=lambda i: _name_key(names[i]))
    if order == list(range(len(paths))):
        return list(paths), None
    for i, j in zip(order, order[1:]):
        if not _numbers_decide(names[i], names[j]):
            raise FormatError(f"import: the channel order of the WAV files is ambiguous: "
                              f"{names[i]} and {names[j]} differ by no number, and the files "
                              "were not given in sorted order; name the files so that numbers "
                              "give the hydrophone order (e.g. h1_stbd.wav h2_port.wav)")
    shown = ", ".join(names[i] for i in order[:4]) + (", ..." if len(order) > 4 else "")
    return [paths[i] for i in order], (f"channels in the natural order of the file names "
                                       f"({shown}), not the order given")


def import_wavs(paths: Sequence[str | os.PathLike], out: str | os.PathLike,
                positions: np.ndarray | None = None, scale: float | None = None,
                sound_speed: float = 1500.0, start_time: str | None = None,
                chunk: int = 1 << 16, warn: Callable[[str], None] | None = None,
                calibration: Calibration | None = None) -> dict:
    """Write audio recordings (WAV; FLAC, AIFF and the rest through :func:`audio_info`) as
    one recording file; returns a summary dict.

    Several files are taken as one mono (or multichannel) stream each, concatenated along
    channels in the natural order of their names (:func:`channel_order`, with a notice when
    that is not the order given); they must share sample rate and sample format. Files of
    unequal length are cut to the shortest, with a warning naming the longer ones. ``scale``
    converts full scale to Pa; so does ``calibration``
    (:class:`arrayproc.io.calibration.Calibration`: a sensitivity, gain and full-scale voltage,
    or a frequency-response sheet), which is also written as the ``/time_data`` attribute
    ``calibration``.
    """
    if not paths:
        raise FormatError("import: no audio files given")
    paths, notice = channel_order(paths)
    if notice is not None:
        (warn or warnings.warn)(notice)
    infos = [audio_info(p) for p in paths]
    ref = infos[0]
    for i in infos[1:]:
        if i.fs != ref.fs:
            raise FormatError(f"{i.path}: sample rate {i.fs} Hz differs from {ref.path.name} "
                              f"({ref.fs} Hz)")
        if (i.bits, i.is_float) != (ref.bits, ref.is_float):
            raise FormatError(f"{i.path}: sample format {i.kind} differs from {ref.path.name} "
                              f"({ref.kind})")
    for i in infos:
        if i.missing_frames and warn is not None:
            warn(f"{i.path}: truncated WAV: the header declares {i.n_frames + i.missing_frames} "
                 f"samples, the file holds {i.n_frames}; importing those")
    n = min(i.n_frames for i in infos)
    longer = [f"{i.path.name} (+{i.n_frames - n} samples)" for i in infos if i.n_frames > n]
    if longer and warn is not None:
        warn(f"files of unequal length, cut to the shortest ({n} samples): {', '.join(longer)}")
    n_ch = sum(i.n_channels for i in infos)
    if positions is not None and len(positions) != n_ch:
        raise FormatError(f"geometry has {len(positions)} positions but the WAV files hold "
                          f"{n_ch} channels")
    fir = None
    if calibration is not None:
        scale, fir = calibration.scale(), calibration.response_filter(ref.fs)
    with RecordingWriter(out, ref.fs, n_ch, positions=positions, sound_speed=sound_speed,
                         start_time=start_time, units="Pa" if scale or fir else "FS",
                         attrs={"imported_from": ", ".join(str(i.path.name) for i in infos)},
                         expected_samples=n) as w:
        if calibration is not None:
            w.set_calibration(calibration.describe())
        for s in range(0, n, chunk):
            c = min(chunk, n - s)
            block = np.concatenate([read_frames(i, s, c) for i in infos], axis=1)
            if scale:
                block *= scale
            if fir is not None:
                block = fir.process(block)
            w.append(block.astype(np.float32))
        tail = fir.flush() if fir is not None else None
        if tail is not None and tail.shape[0]:
            w.append(tail.astype(np.float32))
    return {"fs": ref.fs, "n_channels": n_ch, "n_samples": n, "format": ref.kind,
            "cut": longer}
