"""Calibration of imported recordings: full-scale samples → pascals.

A recorder stores a fraction of its full scale; the pressure behind it follows from the
hydrophone's sensitivity ``S`` (dB re 1 V/µPa), the gain ``G`` (dB) between hydrophone and
converter and the voltage ``V_FS`` (V) of the converter's full scale:

    p [µPa] = x [FS] · V_FS / 10^((S + G) / 20),       p [Pa] = 10⁻⁶ · p [µPa].      (1)

A flat sensitivity makes (1) one factor (:func:`pascals_per_full_scale`). A sensitivity that
varies with frequency (a calibration sheet, read by :func:`read_response`: rows of frequency
Hz and sensitivity dB re 1 V/µPa) makes (1) a filter: its inverse response ``k(f) = 10⁻⁶ V_FS /
10^((S(f) + G)/20)``, interpolated linearly in dB on frequency and held beyond the sheet's
ends, is designed as a linear-phase FIR (``scipy.signal.firwin2``) and applied in overlap-add
blocks with its delay removed (:class:`ResponseFilter`), so the stream stays aligned with the
samples and keeps its length. scipy does the design and the convolutions; only the streaming
(the carried tail and the delay) is written here, because ``scipy.signal.lfilter`` with a
long FIR costs a multiply-add per tap and sample.
"""

from __future__ import annotations

import csv
import math
import os
from dataclasses import dataclass

import numpy as np

from arrayproc.errors import FormatError

#: FIR length of a frequency-response correction (odd: a whole-sample delay).
RESPONSE_TAPS = 1025


def pascals_per_full_scale(sensitivity_db: float, gain_db: float = 0.0,
                           full_scale_volts: float = 1.0) -> float:
    """Pa per unit of full scale for a flat sensitivity, eq. (1).

    Parameters
    ----------
    sensitivity_db : float
        Hydrophone sensitivity, dB re 1 V/µPa (e.g. −170).
    gain_db : float
        Gain between hydrophone and converter, dB.
    full_scale_volts : float
        Voltage of the converter's full scale (sample value 1), V, > 0.

    Returns
    -------
    float
        The factor that turns samples in full scale into pascals.
    """
    return 1e-6 * full_scale_volts / 10.0 ** ((sensitivity_db + gain_db) / 20.0)


def read_response(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray]:
    """A frequency-response CSV: ``freq_hz, sensitivity_db`` rows (dB re 1 V/µPa).

    A first line that is not two numbers is taken as a header; blank lines and lines starting
    with ``#`` are skipped. Frequencies must be finite, ≥ 0 and strictly increasing, with at
    least one row.

    Returns
    -------
    (freq_hz, sensitivity_db) : two (n,) arrays
    """
    try:
        with open(path, encoding="utf-8", newline="") as f:
            rows = [r for r in csv.reader(f) if r and not r[0].lstrip().startswith("#")
                    and any(c.strip() for c in r)]
    except FileNotFoundError:
        raise FormatError(f"{path}: no such frequency-response file") from None
    except (OSError, UnicodeDecodeError) as e:
        raise FormatError(f"{path}: cannot read the frequency response ({e})") from None
    vals = []
    for i, r in enumerate(rows):
        try:
            if len(r) < 2:
                raise ValueError
            vals.append((float(r[0]), float(r[1])))
        except ValueError:
            if i == 0:
                continue  # header
            raise FormatError(f"{path}: line {i + 1}: expected freq_hz, sensitivity_db "
                              f"numbers, got {','.join(r)!r}") from None
    if not vals:
        raise FormatError(f"{path}: no rows of freq_hz, sensitivity_db")
    a = np.asarray(vals, float)
    if not np.all(np.isfinite(a)) or np.any(a[:, 0] < 0) or np.any(np.diff(a[:, 0]) <= 0):
        raise FormatError(f"{path}: frequencies must be finite, >= 0 and strictly increasing, "
                          "and sensitivities finite")
    return a[:, 0], a[:, 1]


class ResponseFilter:
    """The inverse of a frequency response as a streaming linear-phase FIR (module doc).

    Parameters
    ----------
    freq_hz, sensitivity_db : (n,) arrays
        The sensitivity sheet, dB re 1 V/µPa.
    fs : float
        Sample rate, Hz.
    gain_db, full_scale_volts : float
        As in :func:`pascals_per_full_scale`.
    taps : int
        FIR length (odd).

    Call :meth:`process` with consecutive blocks (n, channels) and :meth:`flush` at the end:
    the outputs concatenated have the input's length and are aligned with it.
    """

    def __init__(self, freq_hz: np.ndarray, sensitivity_db: np.ndarray, fs: float,
                 gain_db: float = 0.0, full_scale_volts: float = 1.0,
                 taps: int = RESPONSE_TAPS) -> None:
        from scipy.signal import firwin2
        taps = int(taps) | 1
        grid = np.linspace(0.0, fs / 2, taps // 2 + 1)
        s_db = np.interp(grid, freq_hz, sensitivity_db)
        k = 1e-6 * full_scale_volts / 10.0 ** ((s_db + gain_db) / 20.0)
        self.h = firwin2(taps, grid, k, fs=fs, window="blackmanharris")
        self.delay = (taps - 1) // 2
        self._tail: np.ndarray | None = None
        self._drop = self.delay

    def process(self, x: np.ndarray) -> np.ndarray:
        """Filter one block (n, channels); returns the samples that are complete (the first
        call returns ``delay`` fewer than given, :meth:`flush` the rest)."""
        from scipy.signal import oaconvolve
        x = np.asarray(x, float)
        y = oaconvolve(x, self.h[:, None], axes=0) if x.shape[0] else np.zeros(
            (self.h.size - 1, x.shape[1]))
        if self._tail is not None:
            y[:self._tail.shape[0]] += self._tail
        n = x.shape[0]
        self._tail = y[n:].copy()
        out = y[:n]
        if self._drop:
            d = min(self._drop, out.shape[0])
            out, self._drop = out[d:], self._drop - d
        return out

    def flush(self) -> np.ndarray:
        """The last ``delay`` samples (what the delay held back)."""
        if self._tail is None:
            return np.zeros((0, 1))
        return self._tail[self._drop:self.delay]


@dataclass(frozen=True)
class Calibration:
    """How an import turns full scale into pascals: a flat sensitivity (``sensitivity_db``) or
    a frequency-response sheet (``response``), with ``gain_db`` and ``full_scale_volts``."""

    sensitivity_db: float | None = None
    gain_db: float = 0.0
    full_scale_volts: float = 1.0
    response: str | None = None

    def check(self) -> None:
        """Raise FormatError for a value eq. (1) cannot use."""
        if (self.sensitivity_db is None) == (self.response is None):
            raise FormatError("calibration: give either --sensitivity or --response")
        for name, v in (("--sensitivity", self.sensitivity_db), ("--gain", self.gain_db)):
            if v is not None and not math.isfinite(v):
                raise FormatError(f"{name} must be a finite number of dB, got {v:g}")
        if not (math.isfinite(self.full_scale_volts) and self.full_scale_volts > 0):
            raise FormatError(f"--full-scale-volts must be a finite number > 0 V, got "
                              f"{self.full_scale_volts:g}")

    def describe(self) -> str:
        """One line for the recording's ``calibration`` attribute."""
        s = (f"sensitivity {self.sensitivity_db:g} dB re 1 V/µPa" if self.response is None
             else f"frequency response {os.path.basename(self.response)}")
        return f"{s}, gain {self.gain_db:g} dB, full scale {self.full_scale_volts:g} V"

    def scale(self) -> float | None:
        """Pa per full scale for a flat sensitivity, None for a response sheet."""
        if self.response is not None:
            return None
        return pascals_per_full_scale(self.sensitivity_db, self.gain_db, self.full_scale_volts)

    def response_filter(self, fs: float) -> ResponseFilter | None:
        """The streaming correction for a response sheet at rate ``fs``, else None."""
        if self.response is None:
            return None
        f, s = read_response(self.response)
        return ResponseFilter(f, s, fs, self.gain_db, self.full_scale_volts)
