"""Wideband Doppler matched-filter bank (thesis eqs. (4.7)-(4.8)) by FFT fast correlation.

A ping's beams arrive as complex baseband series at ``fs_bb`` around ``f0`` (the K DFT bins
f0 + k fs_bb / K of the receive window). The echo of a scatterer at range rate rdot (positive
opening) is the pulse time-scaled by d = (c - rdot)/(c + rdot) (eq. (4.8)), so the bank holds
one replica p(d t) per range-rate channel. Its spectrum is evaluated exactly from the sampled
replica by the chirp-z transform (scipy.signal.zoom_fft): FT{p(d t)}(f) = P(f/d)/d, at the same
bins as the data, so the correlation of eq. (4.7),

    chi(tau, d) = sum_t x(t) conj(p(d (t - tau))),

is ``ifft(X * conj(P_d))`` per beam and channel: one inverse FFT per cell row, the data's FFT
shared by every replica. Each replica spectrum is scaled to unit energy, so white noise gives
the same output power in every channel. A Doppler-insensitive waveform (HFM, LFM) gets one
replica (d = 1).

Resolutions of the BPSK (thesis eqs. (4.3)-(4.5)): :func:`doppler_resolution`,
:func:`range_resolution`, :func:`sidelobe_level_db`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.fft as sfft
from scipy.signal import zoom_fft

from arrayproc.dsp.fft import BufferedPlan
from arrayproc.errors import ConfigError

from . import _kernels as K

DOPPLER_INSENSITIVE = ("hfm", "lfm")


def doppler_scale(range_rate: np.ndarray | float, c: float) -> np.ndarray:
    """Two-way Doppler time scale d = (c - rdot)/(c + rdot), thesis eq. (4.8).

    Parameters
    ----------
    range_rate : float or ndarray
        Range rate, m/s, positive opening.
    c : float
        Sound speed, m/s.

    Returns
    -------
    ndarray
        d (dimensionless; < 1 for an opening scatterer: a stretched echo).
    """
    r = np.asarray(range_rate, float)
    return (c - r) / (c + r)


def range_rate_grid(spec: dict | None, fc: float, duration: float, c: float,
                    insensitive: bool) -> np.ndarray:
    """Range-rate channels (m/s) from ``{min, max, step}``; default +-15 m/s at the two-way
    3 dB Doppler resolution of the waveform (:func:`doppler_resolution`). A Doppler-insensitive
    waveform gets the single channel 0.

    Parameters
    ----------
    spec : dict or None
        ``{min, max, step}`` m/s (any key may be left out).
    fc, duration : float
        Carrier (Hz) and pulse length (s) of the waveform.
    c : float
        Sound speed, m/s.
    insensitive : bool
        Doppler-insensitive waveform (HFM, LFM).

    Returns
    -------
    (D,) ndarray
    """
    if insensitive:
        return np.zeros(1)
    spec = dict(spec or {})
    unknown = set(spec) - {"min", "max", "step"}
    if unknown:
        raise ConfigError(f"key 'range_rate': unknown key {sorted(unknown)[0]!r} (expected "
                          "min, max, step)")
    lo = float(spec.get("min", -15.0))
    hi = float(spec.get("max", 15.0))
    step = float(spec.get("step", doppler_resolution(fc, duration, c)))
    if not (step > 0 and hi >= lo and abs(hi) < c and abs(lo) < c):
        raise ConfigError(f"key 'range_rate': need step > 0 and min <= max, got {spec}")
    n = int(np.floor((hi - lo) / step + 1e-9)) + 1
    return lo + step * np.arange(n)


def doppler_resolution(fc: float, duration: float, c: float) -> float:
    """Two-way 3 dB Doppler resolution (m/s) of a pulse of length T at carrier fc:
    0.886 c / (2 fc T). Thesis eq. (4.3) prints 0.886 c/(fc T), the one-way value; with the
    two-way scale of eq. (4.8) the carrier moves by 2 rdot fc / c, which halves it."""
    return 0.886 * c / (2.0 * fc * duration)


def range_resolution(bandwidth: float, c: float) -> float:
    """3 dB range resolution 0.886 c / (2 B), thesis eq. (4.4) (m)."""
    return 0.886 * c / (2.0 * bandwidth)


def sidelobe_level_db(bits: int) -> float:
    """Mean sidelobe plateau -10 log10 N of an N-bit BPSK, thesis eq. (4.5) (dB)."""
    return -10.0 * np.log10(bits)


@dataclass(frozen=True)
class BandPlan:
    """Where a ping's complex baseband sits in the receive window's DFT.

    ``n_fft`` (M) points at ``fs`` cover the window; bins ``k0 ... k0 + n_bins - 1`` form the
    baseband, ``f0 = k0 fs / M`` its lowest frequency and ``fs_bb = n_bins fs / M`` its rate.
    """

    fs: float
    n_fft: int
    k0: int
    n_bins: int

    @property
    def df(self) -> float:
        return self.fs / self.n_fft

    @property
    def f0(self) -> float:
        return self.k0 * self.df

    @property
    def fs_bb(self) -> float:
        return self.n_bins * self.df


def band_plan(fs: float, n_samples: int, band: tuple[float, float]) -> BandPlan:
    """FFT size and baseband bins for a receive window of ``n_samples`` at ``fs`` and a band.

    Parameters
    ----------
    fs : float
        Recording rate, Hz.
    n_samples : int
        Samples in the receive window (the FFT is at least this long, fast length).
    band : (float, float)
        Band to keep, Hz (widened to a fast number of bins, centred on the band).

    Returns
    -------
    BandPlan
    """
    lo, hi = band
    if not (0 <= lo < hi <= fs / 2):
        raise ConfigError(f"key 'band': [{lo:g}, {hi:g}] Hz must lie within [0, fs/2 = "
                          f"{fs / 2:g}] Hz")
    m = sfft.next_fast_len(int(n_samples))
    df = fs / m
    k = sfft.next_fast_len(int(np.ceil((hi - lo) / df)) + 1)
    k0 = int(round(0.5 * (lo + hi) / df)) - k // 2
    k0 = max(0, min(k0, m // 2 + 1 - k))
    return BandPlan(float(fs), m, k0, k)


def replica_spectra(replica: np.ndarray, fs: float, f0: float, df: float, n: int,
                    scales: np.ndarray, map_fn=map) -> np.ndarray:
    """Conjugate spectra of the Doppler-scaled replicas p(d t) at f0 + j df, j = 0 ... n-1.

    Parameters
    ----------
    replica : (L,) ndarray
        Transmitted pulse, samples at ``fs`` (sample 0 at the pulse's start).
    fs : float
        Its rate, Hz.
    f0, df : float
        First frequency and spacing, Hz.
    n : int
        Number of frequencies.
    scales : (D,) ndarray
        Doppler time scales d (eq. (4.8)).
    map_fn : callable
        ``map``-like, to spread the channels over threads (each channel is computed alone,
        so the result does not depend on it).

    Returns
    -------
    (D, n) complex64
        conj(P(f/d)/d), each row scaled to unit energy.
    """
    x = np.asarray(replica, float)
    sc = np.asarray(scales, float)
    top = (f0 + (n - 1) * df) / sc
    if np.any(top >= fs / 2):
        raise ConfigError(f"replica: Doppler-scaled band reaches {top.max():g} Hz above fs/2")
    out = np.empty((sc.size, n), np.complex64)

    def one(i: int) -> None:
        d = sc[i]
        lo = f0 / d
        if n > 1:
            s = zoom_fft(x, [lo, top[i]], m=n, fs=fs, endpoint=True)
        else:
            s = np.array([np.sum(x * np.exp(-2j * np.pi * lo * np.arange(x.size) / fs))])
        s = np.conj(s) / d
        out[i] = s / np.sqrt(np.sum(np.abs(s) ** 2))
    list(map_fn(one, range(sc.size)))
    return out


# Rows of a correlator group: 4 rows of a 37 500-bin bank (1.2 MB complex64) stay in the
# level-2 cache from the multiply through the inverse FFT to the square law. Measured on the
# project's machine, one beam of 271 x 37 500, one thread: 46 ms with the whole (D, K) batch
# (three passes over 81 MB), 34 ms in groups of 4 (docs/performance/active.md).
GROUP_BYTES = 1 << 21


class Correlator:
    """Square-law matched-filter rows of one beam at a time, for one bank shape (D, K):
    ``out[d] = |ifft(spec * bank[d])[r0:r0 + R]|^2``.

    The rows go through in groups small enough for the cache (:data:`GROUP_BYTES`): per group
    the multiply, the in-place inverse FFT (:class:`arrayproc.dsp.fft.BufferedPlan`, ducc0
    when installed) and the square law, so each group is read from memory once. Each row's
    transform is the same whatever the group size (the FFT of a batch is the FFT of each
    row), so the output is the same bytes as one (D, K) batch. Runs on one thread; the callers
    give each worker thread its own Correlator.
    """

    def __init__(self, d: int, k: int) -> None:
        self.d = int(d)
        self.g = max(1, min(self.d, GROUP_BYTES // (8 * max(int(k), 1))))
        self.plan = BufferedPlan("ifft", (self.g, k), np.complex64, axis=1, inplace=True)
        rest = self.d % self.g
        self.tail = (BufferedPlan("ifft", (rest, k), np.complex64, axis=1, inplace=True)
                     if rest else None)

    def __call__(self, spec: np.ndarray, bank: np.ndarray, out: np.ndarray,
                 r0: int = 0) -> None:
        """Fill ``out`` (D, R) float32.

        Parameters
        ----------
        spec : (K,) complex64
            FFT of the beam's baseband series.
        bank : (D, K) complex64
            From :func:`replica_spectra`.
        out : (D, R) float32
            |chi|^2 for lags r0 ... r0 + R - 1 (baseband samples).
        r0 : int
            First lag kept.
        """
        g = self.g
        for a in range(0, self.d, g):
            plan = self.plan if a + g <= self.d else self.tail
            e = a + plan.input.shape[0]
            K.mul_rows(bank[a:e], spec, plan.input)
            K.power_rows(plan(), int(r0), out[a:e])


def correlate(spec: np.ndarray, bank: np.ndarray, out: np.ndarray, r0: int = 0) -> None:
    """One-off :class:`Correlator` call (tests, scripts): ``out[d] = |ifft(spec bank[d])|^2``
    from lag r0 on."""
    Correlator(*bank.shape)(np.ascontiguousarray(spec, np.complex64),
                            np.ascontiguousarray(bank, np.complex64), out, r0)
