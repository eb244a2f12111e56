"""Deterministic, chunk-independent signal generators: shaped Gaussian noise and tonals.

Every random stream is cut into fixed frames of ``frame`` samples keyed by their absolute
index; frame k's white noise comes from ``default_rng(SeedSequence(seed, spawn_key=key+(k,)))``,
so a sample's value never depends on how the caller chunks its requests (same seed → same
bytes). Colour is applied by a linear-phase FIR (frequency sampling, Hann-windowed) with
overlap-save over frames k−1, k.

Levels: a one-sided power spectral density P(f) in Pa²/Hz (P = 1e-12 · 10^(L/10) for a level L
in dB re 1 µPa²/Hz). White Gaussian samples of variance P_ref · fs / 2 have the one-sided PSD
P_ref; the FIR's gain |H(f)|² = P(f)/P_ref shapes it.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Callable

import numpy as np

from arrayproc.dsp import fft

UPA2 = 1e-12  # (1 µPa)² in Pa²
FRAME = 8192
FIR_LEN = 2047
KEY_OFFSET = 1 << 40  # spawn keys must be >= 0; frames may have negative indices


def level_to_psd(level_db: np.ndarray | float) -> np.ndarray:
    """dB re 1 µPa²/Hz → Pa²/Hz."""
    return UPA2 * 10.0 ** (np.asarray(level_db, dtype=float) / 10.0)


def design_shaping_fir(fs: float, psd: Callable[[np.ndarray], np.ndarray], p_ref: float,
                       n_taps: int = FIR_LEN) -> np.ndarray:
    """Linear-phase FIR (n_taps, odd) whose power gain approximates psd(f)/p_ref."""
    n_fft = 4 * (n_taps + 1)
    f = np.arange(n_fft // 2 + 1) * fs / n_fft
    mag = np.sqrt(np.maximum(psd(f), 0.0) / p_ref)
    h = np.fft.irfft(mag, n_fft)
    half = n_taps // 2
    h = np.concatenate([h[-half:], h[:half + 1]]) * np.hanning(n_taps + 2)[1:-1]
    return h


class ShapedNoise:
    """Gaussian noise with a given PSD in ``n_streams`` independent streams, by absolute index.

    Parameters
    ----------
    fs : float
        Sample rate, Hz.
    seed, key :
        Root seed and a tuple of non-negative ints naming this stream family.
    n_streams : int
        Independent columns (e.g. one per hydrophone).
    psd : callable or None
        One-sided PSD f (Hz) → Pa²/Hz; None with ``white_psd`` for flat noise (no filter).
    white_psd : float
        PSD (Pa²/Hz) of the white case, or the reference level the FIR is normalised to.
    """

    def __init__(self, fs: float, seed: int, key: tuple[int, ...], n_streams: int = 1,
                 psd: Callable[[np.ndarray], np.ndarray] | None = None,
                 white_psd: float = UPA2, frame: int = FRAME, dtype=np.float64) -> None:
        self.fs = float(fs)
        self.seed = int(seed)
        self.key = tuple(int(k) for k in key)
        self.n_streams = int(n_streams)
        self.frame = int(frame)
        self.dtype = dtype
        self.sigma = np.sqrt(white_psd * fs / 2.0)
        self.fir = None
        if psd is not None:
            self.fir = design_shaping_fir(fs, psd, white_psd, min(FIR_LEN, frame - 1))
            n_fft = fft.next_fast_len(2 * frame)
            self._n_fft = n_fft
            self._H = fft.rfft(self.fir, n_fft)[:, None]
        self._white: OrderedDict[int, np.ndarray] = OrderedDict()
        self._out: OrderedDict[int, np.ndarray] = OrderedDict()

    def _white_frame(self, k: int) -> np.ndarray:
        w = self._white.get(k)
        if w is None:
            ss = np.random.SeedSequence(self.seed, spawn_key=self.key + (k + KEY_OFFSET,))
            rng = np.random.default_rng(ss)
            dt = np.float32 if (self.fir is None and self.dtype == np.float32) else np.float64
            w = rng.standard_normal((self.frame, self.n_streams), dtype=dt)
            w *= dt(self.sigma)
            self._white[k] = w
            if len(self._white) > 4:
                self._white.popitem(last=False)
        return w

    def _frame(self, k: int) -> np.ndarray:
        y = self._out.get(k)
        if y is None:
            if self.fir is None:
                y = self._white_frame(k)
            else:
                x = np.concatenate([self._white_frame(k - 1), self._white_frame(k)])
                y = fft.irfft(fft.rfft(x, self._n_fft, axis=0) * self._H, self._n_fft, axis=0)
                # outputs [F, 2F) of the linear convolution only see [w_{k-1}, w_k]
                # (the FIR is shorter than a frame); the FIR's constant group delay is
                # immaterial for stationary noise
                y = y[self.frame: 2 * self.frame]
            y = y.astype(self.dtype, copy=False)
            self._out[k] = y
            if len(self._out) > 4:
                self._out.popitem(last=False)
        return y

    def block(self, m0: int, m1: int) -> np.ndarray:
        """Samples [m0, m1) (absolute indices, may be negative) → (m1 − m0, n_streams)."""
        out = np.empty((m1 - m0, self.n_streams), dtype=self.dtype)
        k = m0 // self.frame
        pos = m0
        while pos < m1:
            f = self._frame(k)
            a = pos - k * self.frame
            b = min(self.frame, m1 - k * self.frame)
            out[pos - m0: pos - m0 + (b - a)] = f[a:b]
            pos += b - a
            k += 1
        return out
