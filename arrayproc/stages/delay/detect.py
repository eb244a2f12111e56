"""Transient detection on one channel: band energy of short frames over a robust background.

Frames of ``nfft`` samples every ``nfft/2`` (Hann window) give the band energy E_k (dB, the
sum of the periodogram over the band's bins). The background B_k is the median of E over a
window of ``background`` seconds centred on frame k (clipped at the stream's ends), so a frame
is decided ``background/2`` seconds after it arrives and memory is bounded by that window. A
frame is active when E_k − B_k ≥ ``threshold_db``; active runs closer than ``merge_gap`` are
merged, runs whose frames span less than ``min_duration`` dropped and runs longer than
``max_duration`` cut. Each event reports its time box (from the start of its first active frame
to the end of its last), SNR (the largest E_k − B_k), and its band: the bins whose event-mean
level exceeds their background median by at least 3 dB and by no less than 10 dB below the
largest excess. No library detects transients this
way in a stream; written by hand on numpy.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np
import scipy.fft as sfft


@dataclass(frozen=True)
class Event:
    """A detection: time box (s since the stream start), band (Hz) and SNR (dB)."""

    time_start: float
    time_end: float
    freq_lo: float
    freq_hi: float
    snr_db: float


class TransientDetector:
    """Streaming detector (see the module docstring).

    Parameters
    ----------
    fs : float
        Sample rate, Hz.
    band : (lo, hi) Hz
        Band of the energy.
    threshold_db : float
        Detection threshold over the background, dB.
    min_duration, merge_gap, max_duration : float
        s.
    nfft : int
        Frame length, samples (hop nfft/2).
    background : float
        Length of the centred median window, s.
    """

    def __init__(self, fs: float, band: tuple[float, float], threshold_db: float = 10.0,
                 min_duration: float = 0.02, merge_gap: float = 0.05, max_duration: float = 2.0,
                 nfft: int = 512, background: float = 5.0) -> None:
        self.fs, self.nfft, self.hop = float(fs), int(nfft), int(nfft) // 2
        f = np.fft.rfftfreq(self.nfft, 1 / fs)
        self.bins = np.flatnonzero((f >= band[0]) & (f <= band[1]))
        if self.bins.size == 0:
            raise ValueError(f"band {band} Hz holds no bin of a {nfft}-point frame at {fs} Hz")
        self.f = f[self.bins]
        self.win = np.hanning(self.nfft)
        self.threshold_db = float(threshold_db)
        self.min_duration = float(min_duration)
        self.gap_frames = max(1, int(np.ceil(merge_gap * fs / self.hop)))
        self.max_frames = max(1, int(max_duration * fs / self.hop))
        self.half = max(1, int(round(background / 2 * fs / self.hop)))
        self._buf = np.zeros(0)
        self._buf0 = 0  # absolute sample of _buf[0]
        self._k_next = 0  # next frame to compute
        self._frames: deque[tuple[int, float, np.ndarray]] = deque()  # (k, E dB, spectrum dB)
        self._k_decide = 0
        self._open: list | None = None  # [k_first, k_last_active, snr, spec_sum, bg_spec, n]

    def push(self, x: np.ndarray, final: bool = False) -> list[Event]:
        """Add the next samples of the channel; return the events closed so far."""
        self._buf = np.concatenate([self._buf, np.asarray(x, float)])
        n_new = (self._buf0 + self._buf.size - self._k_next * self.hop - self.nfft) // self.hop + 1
        if n_new > 0:
            off = self._k_next * self.hop - self._buf0
            idx = off + np.arange(n_new)[:, None] * self.hop + np.arange(self.nfft)
            P = np.abs(sfft.rfft(self._buf[idx] * self.win, axis=1)[:, self.bins]) ** 2
            spec_db = 10 * np.log10(np.maximum(P, 1e-300))
            e_db = 10 * np.log10(np.maximum(P.sum(1), 1e-300))
            for j in range(n_new):
                self._frames.append((self._k_next + j, float(e_db[j]), spec_db[j]))
            self._k_next += n_new
            drop = self._k_next * self.hop - self._buf0
            if drop > 0:
                self._buf = self._buf[drop:]
                self._buf0 += drop
        out: list[Event] = []
        last = self._k_next - 1
        while self._k_decide <= last and (final or self._k_decide + self.half <= last):
            out += self._decide(self._k_decide)
            self._k_decide += 1
            while self._frames and self._frames[0][0] < self._k_decide - self.half:
                self._frames.popleft()
        if final and self._open is not None:
            out += self._close()
        return out

    def _decide(self, k: int) -> list[Event]:
        frames = [fr for fr in self._frames if abs(fr[0] - k) <= self.half]
        e = np.array([fr[1] for fr in frames])
        bg = float(np.median(e))
        cur = next(fr for fr in frames if fr[0] == k)
        excess = cur[1] - bg
        out: list[Event] = []
        o = self._open
        if o is not None and (k - o[1] > self.gap_frames or k - o[0] >= self.max_frames):
            out += self._close()
            o = None
        if excess >= self.threshold_db:
            if o is None:
                bg_spec = np.median(np.stack([fr[2] for fr in frames]), axis=0)
                self._open = [k, k, excess, 10 ** (cur[2] / 10), bg_spec, 1]
            else:
                o[1] = k
                o[2] = max(o[2], excess)
                o[3] = o[3] + 10 ** (cur[2] / 10)
                o[5] += 1
        return out

    def _close(self) -> list[Event]:
        k0, k1, snr, ssum, bg_spec, n = self._open
        self._open = None
        t0 = k0 * self.hop / self.fs  # the active frames' span
        t1 = (k1 * self.hop + self.nfft) / self.fs
        if t1 - t0 < self.min_duration:
            return []
        lvl = 10 * np.log10(np.maximum(ssum / n, 1e-300)) - bg_spec
        hot = np.flatnonzero(lvl >= max(3.0, float(lvl.max()) - 10.0))
        lo, hi = (self.f[hot[0]], self.f[hot[-1]]) if hot.size else (self.f[0], self.f[-1])
        return [Event(t0, t1, float(lo), float(hi), float(snr))]


def detect_transients(x: np.ndarray, fs: float, band: tuple[float, float],
                      **options: float) -> list[Event]:
    """All events of a whole channel at once (:class:`TransientDetector` in one push).

    Parameters
    ----------
    x : (n,) array
        The channel's samples.
    fs : float
        Sample rate, Hz.
    band : (lo, hi) Hz
        Band of the energy.
    **options
        Keyword arguments of :class:`TransientDetector`.

    Returns
    -------
    list of Event
    """
    return TransientDetector(fs, band, **options).push(x, final=True)
