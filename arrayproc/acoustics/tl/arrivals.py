"""BELLHOP arrivals (``.arr``, ASCII, 2-D): amplitude, phase, delay and bounce counts of every
eigenray at each receiver, and their grouping into ray families that can be followed in range.

File layout (BELLHOP / bellhopcxx ``'A'`` run): an optional ``'2D'`` line, the frequency, the
source depths, receiver depths and receiver ranges (each as a count then the values), then
per source depth the largest arrival count and, per receiver depth and range, the number of
arrivals followed by one line per arrival: amplitude, phase (deg), delay (s, real and
imaginary parts), launch and arrival angles (deg), surface and bottom bounce counts.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from arrayproc.errors import FormatError


@dataclass
class Arrivals:
    """Arrivals of one source depth: ``rows[ir][ik]`` an (n, 8) array per receiver depth ir
    and range ik (columns: amp, phase deg, delay s, delay imag, launch deg, arrival deg,
    surface bounces, bottom bounces)."""

    freq: float
    src_depth: float
    rcv_depths: np.ndarray
    ranges: np.ndarray
    rows: list[list[np.ndarray]]


def read_arr(path: str | Path) -> list[Arrivals]:
    """Read an ASCII 2-D arrivals file: one :class:`Arrivals` per source depth."""
    p = Path(path)
    tok = p.read_text().replace("'2D'", " ").split()
    pos = 0

    def take(n: int = 1) -> np.ndarray:
        nonlocal pos
        if pos + n > len(tok):
            raise FormatError(f"{p}: arrivals file ends early")
        v = np.array(tok[pos:pos + n], dtype=float)
        pos += n
        return v

    try:
        freq = float(take()[0])
        sd = take(int(take()[0]))
        rd = take(int(take()[0]))
        rr = take(int(take()[0]))
        out = []
        for s in sd:
            take()  # largest arrival count
            rows = []
            for _ in rd:
                per_r = []
                for _ in rr:
                    n = int(take()[0])
                    per_r.append(take(8 * n).reshape(n, 8))
                rows.append(per_r)
            out.append(Arrivals(freq, float(s), rd, rr, rows))
    except ValueError as e:
        raise FormatError(f"{p}: not a BELLHOP arrivals file ({e})") from None
    return out


def family_tables(arr: Arrivals, ir: int = 0) -> dict[tuple[int, int, int, int], np.ndarray]:
    """Per ray family (surface bounces, bottom bounces, sign of launch and arrival angles):
    (n_ranges, 3) of delay (s), and the complex amplitude's real and imaginary parts
    A·e^{iφ} at the file's frequency, several beams of one family at one range summed
    coherently about their amplitude-weighted delay; amplitude 0 where the family is absent
    (its delay then interpolated from neighbouring ranges, or extrapolated at the ends)."""
    w = 2 * np.pi * arr.freq
    n = arr.ranges.size
    fams: dict[tuple[int, int, int, int], np.ndarray] = {}
    for ik in range(n):
        a = arr.rows[ir][ik]
        if a.size == 0:
            continue
        keys = np.column_stack([a[:, 6], a[:, 7], np.sign(a[:, 4]), np.sign(a[:, 5])]).astype(int)
        for key in {tuple(k) for k in keys}:
            m = np.all(keys == key, axis=1)
            amp, ph, dl = a[m, 0], np.deg2rad(a[m, 1]), a[m, 2]
            tau = float(np.sum(amp * dl) / np.sum(amp))
            z = np.sum(amp * np.exp(1j * (ph - w * (dl - tau))))
            t = fams.setdefault(key, np.full((n, 3), np.nan))
            t[ik] = (tau, z.real, z.imag)
    for t in fams.values():
        ok = np.isfinite(t[:, 0])
        t[~ok, 1:] = 0.0
        if ok.sum() == 1:
            t[~ok, 0] = t[ok, 0][0]
        else:
            idx = np.flatnonzero(ok)
            t[:, 0] = np.interp(np.arange(n), idx, t[idx, 0])
    return fams
