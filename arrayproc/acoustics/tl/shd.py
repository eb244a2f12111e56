"""Reader (and test writer) for BELLHOP/KRAKEN binary shade files (``.shd``).

A ``.shd`` file is a Fortran direct-access file of fixed-length records. The first 4 bytes hold
the record length ``lrecl`` in 4-byte words; record ``k`` starts at byte ``4 * lrecl * k``:

====  ==========================================================================
rec   content
====  ==========================================================================
0     lrecl (int32), title (80 chars)
1     plot type (10 chars)
2     Nfreq, Ntheta, Nsx, Nsy, Nsz, Nrz, Nrr (int32), freq0, atten
3     frequencies (Nfreq)
4     bearings theta (Ntheta, float64)
5, 6  source x, y (Nsx, Nsy)
7     source depths (Nsz, float32)
8     receiver depths (Nrz, float32)
9     receiver ranges (Nrr)
10+   complex64 pressure, one record per (freq, theta, source depth, receiver depth),
      Nrr values
====  ==========================================================================

Two dialects exist: recent Acoustics Toolbox Fortran writes ``freq0``/``atten`` and the
frequency, source-x/y and receiver-range vectors as float64; bellhopcxx/bellhopcuda and older
Fortran builds write ``freq0``/``atten`` and the receiver ranges as float32 (the frequency
vector is float64 in some of them and float32 in others). The reader decides the width of each
vector separately from the bytes, so every combination is read.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from arrayproc.errors import FormatError

__all__ = ["ShadeFile", "read_shd", "write_shd"]


@dataclass
class ShadeFile:
    """Contents of a ``.shd`` file. ``pressure`` has shape (Nfreq, Ntheta, Nsz, Nrz, Nrr)."""

    title: str
    plot_type: str
    freqs: np.ndarray           # Hz
    theta: np.ndarray           # deg (3-D runs), [0] for 2-D
    src_depths: np.ndarray      # m
    rcv_depths: np.ndarray      # m
    ranges: np.ndarray          # m
    pressure: np.ndarray        # complex
    dialect: dict

    def tl(self, ifreq: int = 0, itheta: int = 0, isrc: int = 0) -> np.ndarray:
        """Transmission loss −20 log10 |p| (dB), shape (Nrz, Nrr); +inf where p = 0."""
        p = np.abs(self.pressure[ifreq, itheta, isrc])
        with np.errstate(divide="ignore"):
            return -20.0 * np.log10(p)


def _plausible(v: np.ndarray, monotone: bool, positive: bool) -> bool:
    if v.size == 0:
        return True
    if not np.all(np.isfinite(v)) or np.any(np.abs(v) > 1e9):
        return False
    nz = v[v != 0]
    if nz.size and np.any(np.abs(nz) < 1e-6):     # denormal/tiny: float32 bytes read as float64
        return False
    if positive and np.any(v <= 0):
        return False
    return not (monotone and v.size > 1 and np.any(np.diff(v) < 0))


def _read_vector(buf: bytes, offset: int, n: int, room: int, monotone: bool,
                 positive: bool) -> tuple[np.ndarray, str]:
    """Read ``n`` reals at ``offset``, deciding float64 vs float32 from plausibility."""
    if 8 * n <= room:
        v8 = np.frombuffer(buf, "<f8", n, offset)
        if _plausible(v8, monotone, positive):
            return v8.astype(float), "float64"
    v4 = np.frombuffer(buf, "<f4", n, offset)
    if not _plausible(v4.astype(float), monotone, positive):
        raise FormatError("shd: cannot decode a header vector as float64 or float32")
    return v4.astype(float), "float32"


def read_shd(path: str | Path) -> ShadeFile:
    """Read a BELLHOP ``.shd`` file of either dialect (see the module docstring)."""
    path = Path(path)
    try:
        buf = path.read_bytes()
    except OSError as e:
        raise FormatError(f"{path}: cannot read ({e.strerror})") from None
    if len(buf) < 44:
        raise FormatError(f"{path}: too short for a shade file")
    lrecl = int(np.frombuffer(buf, "<i4", 1, 0)[0])
    rec = 4 * lrecl
    if lrecl <= 0 or len(buf) < 10 * rec:
        raise FormatError(f"{path}: bad record length {lrecl}")
    title = buf[4:84].decode("ascii", "replace").strip()
    plot_type = buf[rec:rec + 10].decode("ascii", "replace").strip()
    nfreq, ntheta, nsx, nsy, nsz, nrz, nrr = (int(x) for x in np.frombuffer(buf, "<i4", 7, 2 * rec))
    if min(nfreq, ntheta, nsz, nrz, nrr) <= 0:
        raise FormatError(f"{path}: bad dimensions in the header")
    freqs, ff = _read_vector(buf, 3 * rec, nfreq, rec, monotone=False, positive=True)
    theta = np.frombuffer(buf, "<f8", ntheta, 4 * rec).astype(float)
    src_z = np.frombuffer(buf, "<f4", nsz, 7 * rec).astype(float)
    rcv_z = np.frombuffer(buf, "<f4", nrz, 8 * rec).astype(float)
    ranges, fr = _read_vector(buf, 9 * rec, nrr, rec, monotone=True, positive=False)
    n_rec = nfreq * ntheta * nsz * nrz
    need = (10 + n_rec) * rec
    if len(buf) < need - rec + 8 * nrr:
        raise FormatError(f"{path}: truncated: {len(buf)} bytes, expected {need}")
    p = np.empty((n_rec, nrr), dtype=np.complex64)
    for i in range(n_rec):
        p[i] = np.frombuffer(buf, "<c8", nrr, (10 + i) * rec)
    return ShadeFile(title, plot_type, freqs, theta, src_z, rcv_z, ranges,
                     p.reshape(nfreq, ntheta, nsz, nrz, nrr),
                     {"freqs": ff, "ranges": fr})


def write_shd(path: str | Path, pressure: np.ndarray, freqs, src_depths, rcv_depths, ranges,
              dialect: str = "float64", title: str = "arrayproc", theta=(0.0,)) -> None:
    """Write a ``.shd`` file in the ``"float64"`` (recent Acoustics Toolbox) or ``"float32"``
    (bellhopcxx/older) dialect. Used to test the reader; ``pressure`` is
    (Nfreq, Ntheta, Nsz, Nrz, Nrr) complex.
    """
    if dialect not in ("float64", "float32"):
        raise ValueError("dialect must be 'float64' or 'float32'")
    p = np.asarray(pressure, dtype=np.complex64)
    nfreq, ntheta, nsz, nrz, nrr = p.shape
    wide = "<f8" if dialect == "float64" else "<f4"
    lrecl = max(2 * nrr, 2 * nfreq, 2 * ntheta, 2 * nrz, 2 * nsz, 32)
    rec = 4 * lrecl
    out = bytearray(rec * (10 + nfreq * ntheta * nsz * nrz))

    def put(k: int, data: bytes, skip: int = 0) -> None:
        out[k * rec + skip:k * rec + skip + len(data)] = data

    put(0, np.int32(lrecl).tobytes())
    put(0, title.encode("ascii")[:80].ljust(80), 4)
    put(1, b"rectilin  ")
    put(2, np.array([nfreq, ntheta, 1, 1, nsz, nrz, nrr], "<i4").tobytes()
        + np.array([np.asarray(freqs).ravel()[0], 0.0], wide).tobytes())
    put(3, np.asarray(freqs, wide).tobytes())
    put(4, np.asarray(theta, "<f8").tobytes())
    put(5, np.zeros(1, wide).tobytes())
    put(6, np.zeros(1, wide).tobytes())
    put(7, np.asarray(src_depths, "<f4").tobytes())
    put(8, np.asarray(rcv_depths, "<f4").tobytes())
    put(9, np.asarray(ranges, wide).tobytes())
    for i, row in enumerate(p.reshape(-1, nrr)):
        put(10 + i, row.astype("<c8").tobytes())
    Path(path).write_bytes(bytes(out))
