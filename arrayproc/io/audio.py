"""Audio files other than WAV (FLAC, AIFF, CAF, W64, …) read through ``soundfile``
(libsndfile), and the beam WAVs of ``arrayproc listen`` written through it.

WAV files keep their hand-written reader (:mod:`arrayproc.io.wav`, which sends every other
file here, :func:`arrayproc.io.wav.audio_info`): it reads truncated files
and the RF64/streamed headers of field recorders and says what it found, which libsndfile
refuses or hides. Every other format goes to libsndfile, which decodes FLAC and AIFF (and what
else it knows) to floats in full scale; ``soundfile`` is an optional dependency (extra
``labelled``) and is imported only for those files.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from arrayproc.errors import FormatError

_BITS = {"PCM_S8": 8, "PCM_U8": 8, "PCM_16": 16, "PCM_24": 24, "PCM_32": 32, "FLOAT": 32,
         "DOUBLE": 64}


@dataclass
class SoundfileInfo:
    """What libsndfile says of an audio file, with the fields of
    :class:`arrayproc.io.wav.WavInfo` the import uses (rate, channels, sample format,
    frames)."""

    path: Path
    fs: int
    n_channels: int
    bits: int
    is_float: bool
    n_frames: int
    format: str
    missing_frames: int = 0

    @property
    def kind(self) -> str:
        return f"{self.format} {self.bits}-bit {'float' if self.is_float else 'PCM'}"


def _soundfile():
    try:
        import soundfile
    except ImportError:  # pragma: no cover - the extra is not installed
        raise FormatError("reading FLAC, AIFF and other non-WAV audio needs the soundfile "
                          "package (pip install 'arrayproc[labelled]')") from None
    return soundfile


def soundfile_info(path: str | os.PathLike) -> SoundfileInfo:
    """The header of an audio file libsndfile reads (FormatError when it cannot)."""
    p = Path(path)
    if not p.is_file():
        raise FormatError(f"{p}: no such audio file")
    sf = _soundfile()
    try:
        i = sf.info(str(p))
    except (RuntimeError, sf.LibsndfileError) as e:
        raise FormatError(f"{p}: not an audio file libsndfile reads ({e})") from None
    if i.frames <= 0 or i.channels < 1 or i.samplerate < 1:
        raise FormatError(f"{p}: audio file has {i.frames} frames, {i.channels} channels at "
                          f"{i.samplerate} Hz")
    return SoundfileInfo(p, int(i.samplerate), int(i.channels), _BITS.get(i.subtype, 0),
                         i.subtype in ("FLOAT", "DOUBLE"), int(i.frames), str(i.format))


def soundfile_frames(info: SoundfileInfo, start: int, count: int) -> np.ndarray:
    """Frames [start, start + count) as float64 fractions of full scale, (count, channels)."""
    count = max(0, min(count, info.n_frames - start))
    sf = _soundfile()
    return sf.read(str(info.path), frames=count, start=start, dtype="float64",
                   always_2d=True)[0]


def write_beam_wav(path: str | os.PathLike, samples: np.ndarray, fs: float,
                   peak_dbfs: float = -1.0, units: str = "Pa", what: str = "") -> float:
    """Write a beam (or any mono series) as a 24-bit WAV normalised to ``peak_dbfs``,
    atomically (:mod:`arrayproc.io.atomic`).

    The scale is written in the file's comment (``1 FS = X Pa``), so levels can be read back
    from the WAV; a silent series is written as zeros.

    Parameters
    ----------
    path : str or path-like
        WAV file.
    samples : (n,) array
        The series, in ``units``.
    fs : float
        Sample rate, Hz (rounded to a whole number, as WAV stores it).
    peak_dbfs : float
        Peak of the written samples, dB re full scale (≤ 0).
    units : str
        Unit of ``samples`` (``"Pa"``, ``"FS"``), for the comment.
    what : str
        What the series is (``cone 60 deg``), for the comment.

    Returns
    -------
    float
        Units per full scale of the written file (the normalisation).
    """
    from arrayproc.io.atomic import check_stop, commit, discard, temporary_sibling
    sf = _soundfile()
    y = np.asarray(samples, np.float64).reshape(-1)
    peak = float(np.max(np.abs(y))) if y.size else 0.0
    per_fs = peak / 10.0 ** (peak_dbfs / 20.0) if peak > 0 else 1.0
    tmp = temporary_sibling(path)
    try:
        with sf.SoundFile(str(tmp), "w", samplerate=int(round(fs)), channels=1,
                          format="WAV", subtype="PCM_24") as f:
            f.comment = (f"arrayproc beam{': ' + what if what else ''}; 1 FS = {per_fs:.6g} "
                         f"{units}")
            f.write(y / per_fs)
        check_stop()
        commit(tmp, path)
    except BaseException:
        discard(tmp)
        raise
    return per_fs
