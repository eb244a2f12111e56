"""Active-sonar waveforms (thesis ch. 4): BPSK from m-sequences, HFM, CW; the wideband
ambiguity function; two-way Doppler scale and the time distortion of thesis eq. (4.6).

A :class:`Waveform` is an analytic function of pulse time t (s, 0 at the pulse's start, zero
outside [0, T]) so it can be evaluated at any time, including Doppler-scaled times d·t, and
sampled at any rate. Amplitude: unit peak before the taper (RMS 1/√2 over the pulse).

- BPSK, thesis eq. (4.1): w(t) = (2β(t) − 1) · sin(2π f_c t), β the m-sequence bit of
  duration T/N; 3 dB bandwidth B = N/T (eq. (4.2)); Doppler resolution ≈ 0.886 c/(f_c T)
  (eq. (4.3)); range resolution ≈ 0.886 c/(2B) (eq. (4.4)); sidelobe level −10 log10 N
  (eq. (4.5)).
- HFM: period linear in time, 1/f(t) = 1/f0 − k t with k = (1/f0 − 1/f1)/T, phase
  φ(t) = −(2π/k) ln(1 − k f0 t): Doppler tolerant.
- CW: sin(2π f_c t).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from arrayproc.dsp import fft

# Feedback taps (1-indexed register stages) of primitive polynomials, Fibonacci LFSR.
MLS_TAPS: dict[int, tuple[int, ...]] = {
    2: (2, 1), 3: (3, 2), 4: (4, 3), 5: (5, 3), 6: (6, 5), 7: (7, 6), 8: (8, 6, 5, 4),
    9: (9, 5), 10: (10, 7), 11: (11, 9), 12: (12, 6, 4, 1), 13: (13, 4, 3, 1),
    14: (14, 5, 3, 1), 15: (15, 14), 16: (16, 15, 13, 4), 17: (17, 14), 18: (18, 11),
    19: (19, 6, 2, 1), 20: (20, 17),
}


def mls(order: int, taps: tuple[int, ...] | None = None) -> np.ndarray:
    """Maximum-length sequence of 2**order − 1 bits (0/1, uint8) from a Fibonacci LFSR.

    Its ±1 version has the two-valued periodic autocorrelation N (lag 0) and −1 (other lags).
    """
    if taps is None:
        if order not in MLS_TAPS:
            raise ValueError(f"m-sequence order must be in {min(MLS_TAPS)}..{max(MLS_TAPS)}")
        taps = MLS_TAPS[order]
    n = (1 << order) - 1
    state = [1] * order
    out = np.empty(n, dtype=np.uint8)
    idx = [t - 1 for t in taps]
    for i in range(n):
        out[i] = state[-1]
        fb = 0
        for j in idx:
            fb ^= state[j]
        state = [fb] + state[:-1]
    return out


def bits_to_order(bits: int) -> int:
    """m-sequence order for a length 2**m − 1 (e.g. 2047 → 11); ValueError otherwise."""
    m = int(np.log2(bits + 1) + 0.5)
    if (1 << m) - 1 != bits or m not in MLS_TAPS:
        raise ValueError(f"BPSK bits must be 2**m - 1 with m in 2..20, got {bits}")
    return m


def tukey(x: np.ndarray, fraction: float) -> np.ndarray:
    """Tukey taper on normalised pulse time x ∈ [0, 1] (cosine ramps over ``fraction``/2 each)."""
    x = np.asarray(x, dtype=float)
    w = ((x >= 0) & (x <= 1)).astype(float)
    if fraction <= 0:
        return w
    r = fraction / 2.0
    lo = (x >= 0) & (x < r)
    hi = (x > 1 - r) & (x <= 1)
    w[lo] = 0.5 * (1 - np.cos(np.pi * x[lo] / r))
    w[hi] = 0.5 * (1 - np.cos(np.pi * (1 - x[hi]) / r))
    return w


@dataclass(frozen=True)
class Waveform:
    """An analytic pulse: ``kind`` in {"bpsk", "hfm", "cw"}, duration T (s).

    ``fc`` carrier (BPSK, CW), ``f0``/``f1`` start/end frequencies (HFM), ``sequence`` the
    BPSK bits, ``taper`` the Tukey fraction (0 = rectangular).
    """

    kind: str
    duration: float
    fc: float = 0.0
    f0: float = 0.0
    f1: float = 0.0
    sequence: np.ndarray = field(default_factory=lambda: np.zeros(0, np.uint8), repr=False)
    taper: float = 0.0

    @property
    def band(self) -> tuple[float, float]:
        """Nominal occupied band (Hz): carrier ± bit rate (BPSK, first nulls), f0..f1 (HFM),
        carrier ± 1/T (CW)."""
        if self.kind == "bpsk":
            b = self.sequence.size / self.duration
            return self.fc - b, self.fc + b
        if self.kind == "hfm":
            return min(self.f0, self.f1), max(self.f0, self.f1)
        return self.fc - 1.0 / self.duration, self.fc + 1.0 / self.duration

    @property
    def bandwidth(self) -> float:
        """3 dB bandwidth (Hz): N/T for BPSK (eq. (4.2)), |f1 − f0| for HFM, 1/T for CW."""
        if self.kind == "bpsk":
            return self.sequence.size / self.duration
        if self.kind == "hfm":
            return abs(self.f1 - self.f0)
        return 1.0 / self.duration

    def __call__(self, t: np.ndarray | float) -> np.ndarray:
        """Pulse value at pulse times t (s); zero outside [0, T]."""
        t = np.asarray(t, dtype=float)
        T = self.duration
        inside = (t >= 0) & (t <= T)
        tt = np.where(inside, t, 0.0)
        if self.kind == "bpsk":
            n = self.sequence.size
            i = np.clip((tt * (n / T)).astype(np.int64), 0, n - 1)
            sign = 2.0 * self.sequence[i].astype(float) - 1.0
            y = sign * np.sin(2 * np.pi * self.fc * tt)
        elif self.kind == "cw":
            y = np.sin(2 * np.pi * self.fc * tt)
        elif self.kind == "hfm":
            if self.f0 == self.f1:
                y = np.sin(2 * np.pi * self.f0 * tt)
            else:
                k = (1.0 / self.f0 - 1.0 / self.f1) / T
                y = np.sin(-(2 * np.pi / k) * np.log1p(-k * self.f0 * tt))
        else:  # pragma: no cover - constructors validate
            raise ValueError(self.kind)
        return np.where(inside, y * tukey(tt / T, self.taper), 0.0)

    def sample(self, fs: float, t0: float = 0.0) -> np.ndarray:
        """Samples at t0 + k/fs covering the pulse (k = 0 … ceil((T − t0)·fs))."""
        n = int(np.ceil((self.duration - t0) * fs)) + 1
        return self(t0 + np.arange(n) / fs)

    def instantaneous_frequency(self, t: np.ndarray) -> np.ndarray:
        """Instantaneous frequency (Hz) of the carrier sweep (BPSK/CW: fc; HFM: hyperbolic)."""
        t = np.asarray(t, dtype=float)
        if self.kind == "hfm" and self.f0 != self.f1:
            k = (1.0 / self.f0 - 1.0 / self.f1) / self.duration
            return 1.0 / (1.0 / self.f0 - k * t)
        return np.full(t.shape, self.fc if self.kind != "hfm" else self.f0)


def bpsk(fc: float, duration: float, bits: int = 2047, taper: float = 0.0) -> Waveform:
    """BPSK pulse of an m-sequence of ``bits`` (2**m − 1) bits, thesis eq. (4.1)."""
    if not (fc > 0 and duration > 0):
        raise ValueError("BPSK needs fc > 0 and duration > 0")
    return Waveform("bpsk", float(duration), fc=float(fc), sequence=mls(bits_to_order(bits)),
                    taper=float(taper))


def hfm(f0: float, f1: float, duration: float, taper: float = 0.0) -> Waveform:
    """Hyperbolic FM sweep from f0 to f1 (Hz) in ``duration`` s."""
    if not (f0 > 0 and f1 > 0 and duration > 0):
        raise ValueError("HFM needs f0, f1 > 0 and duration > 0")
    return Waveform("hfm", float(duration), f0=float(f0), f1=float(f1), taper=float(taper))


def cw(fc: float, duration: float, taper: float = 0.0) -> Waveform:
    """Continuous-wave pulse at fc (Hz) lasting ``duration`` s."""
    if not (fc > 0 and duration > 0):
        raise ValueError("CW needs fc > 0 and duration > 0")
    return Waveform("cw", float(duration), fc=float(fc), taper=float(taper))


def doppler_scale(range_rate: np.ndarray | float, c: float = 1500.0) -> np.ndarray:
    """Two-way Doppler time scale d = (c − ṙ)/(c + ṙ), thesis eq. (4.8) (ṙ > 0 opening)."""
    r = np.asarray(range_rate, dtype=float)
    return (c - r) / (c + r)


def range_rate_from_scale(d: np.ndarray | float, c: float = 1500.0) -> np.ndarray:
    """Inverse of :func:`doppler_scale`: ṙ = c (1 − d)/(1 + d)."""
    d = np.asarray(d, dtype=float)
    return c * (1.0 - d) / (1.0 + d)


def time_distortion(t: np.ndarray, alpha: float, duration: float) -> np.ndarray:
    """Distorted pulse time t + α sin(2πt/T)(1 − cos 2πt/T), thesis eq. (4.6) (α in s)."""
    t = np.asarray(t, dtype=float)
    s = 2 * np.pi * t / duration
    return t + alpha * np.sin(s) * (1.0 - np.cos(s))


def wideband_ambiguity(received: np.ndarray, waveform: Waveform, fs: float,
                       scales: np.ndarray, t0: float = 0.0) -> np.ndarray:
    """Wideband matched-filter output |χ(τ, d)|, thesis eq. (4.7), for each scale d.

    χ(τ, d) = Σ_t x(t) · p(d (t − τ)) / fs, evaluated for lags τ = t0 + k/fs, k = 0 … len(x)−1
    (``received`` starts at time t0) as the envelope of the analytic correlation. Returns an
    array (n_scales, len(received)); scale 1 is the ordinary matched filter.
    """
    x = np.asarray(received, dtype=float)
    n = x.size
    scales = np.asarray(scales, dtype=float)
    reps = [waveform(np.arange(int(np.ceil(waveform.duration / d * fs)) + 1) / fs * d)
            for d in scales]
    L = max(r.size for r in reps)
    m = fft.next_fast_len(n + L)  # one FFT size (and plan) for every scale
    X = fft.rfft(x, m)
    h = np.zeros(m)  # one-sided weights: the inverse FFT gives the analytic correlation
    h[0] = 1.0
    h[1:(m + 1) // 2] = 2.0
    if m % 2 == 0:
        h[m // 2] = 1.0
    out = np.empty((scales.size, n))
    padded = np.zeros(L)
    for i, rep in enumerate(reps):
        padded[:] = 0.0
        padded[: rep.size] = rep
        spec = X * np.conj(fft.rfft(padded, m))
        full = np.zeros(m, dtype=complex)
        full[: spec.size] = spec * h[: spec.size]
        out[i] = np.abs(fft.ifft(full)[:n]) / fs
    return out


def ambiguity_function(waveform: Waveform, fs: float, scales: np.ndarray,
                       max_lag: float) -> tuple[np.ndarray, np.ndarray]:
    """Theoretical wideband ambiguity |χ(τ, d)| of a waveform with itself (normalised to 1 at
    τ = 0, d = 1) over lags −max_lag … +max_lag. Returns (lags (n,), chi (n_scales, n))."""
    pad = int(np.ceil(max_lag * fs))
    x = np.concatenate([np.zeros(pad), waveform.sample(fs), np.zeros(pad)])
    chi = wideband_ambiguity(x, waveform, fs, scales, t0=-pad / fs)
    lags = (np.arange(x.size) - pad) / fs
    keep = np.abs(lags) <= max_lag + 0.5 / fs
    peak = wideband_ambiguity(waveform.sample(fs), waveform, fs, [1.0])[0, 0]
    return lags[keep], chi[:, keep] / peak
