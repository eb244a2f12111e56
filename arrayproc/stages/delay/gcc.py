"""Time delays between hydrophones by generalised cross-correlation (thesis section 3.2.2.1).

The delay of channel ``i`` relative to the reference channel is the lag of the maximum of their
cross-correlation, thesis eq. (3.26), computed through the cross-spectrum, eq. (3.27):

    r_i(τ) = DFT⁻¹( W_k X_i,k X_ref,k* ),   k over the bins of the band [f_lo, f_hi].

``τ_i > 0`` when channel ``i`` hears the sound after the reference (the sign of
:func:`arrayproc.geo.tdoa.predicted_delays`). All channels of all snapshots are transformed in
one batch (zero-padded so the correlation is linear, not circular, over the searched lags), the
cross-spectrum is formed over the band's bins only, and one batch of inverse FFTs gives every
correlation.

Weightings ``W_k`` (Knapp & Carter 1976): ``none`` (plain cross-correlation, the thesis's),
``phat`` (1/|G|, whitening), ``scot`` (1/√(G_ii G_rr)) and ``ml`` (Hannan-Thomson,
|γ|²/(|G|(1 − |γ|²))); the auto-spectra and the coherence γ come from a moving average of
``smooth_bins`` bins (the cross-spectrum is first de-rotated by the plain integer-lag delay so
that the average does not cancel it).

The search is limited to the physically possible lags |τ_i| ≤ |p_i − p_ref|/c (+ margin).
The few highest local maxima of the sampled correlation are refined below one sample (with a
narrow band the sampled value of the right carrier cycle can fall below its neighbour's, so the
highest sample alone is not enough) and the highest refined peak is kept. Refinement is either a
parabola through the three samples around a maximum, or (``interp = "fft"``) the maximum
of the band-limited correlation itself between the samples (the trigonometric
interpolation of the inverse DFT, the limit of Matlab's ``interpft`` oversampling the thesis
uses; Newton steps in :mod:`._kernels`), or (``interp = "sinc"``) the maximum of the sampled
correlation interpolated by a Blackman-windowed sinc of ±16 samples (the same to a few ns
while the band stays below about 0.4 fs, at a small fraction of the cost).

Per delay, ``corr`` is the normalised peak of the plain correlation, ρ = r(τ̂)/√(E_i E_ref), and
the standard deviation follows from the peak's curvature and ρ, read as the coherence γ = S/(S+N)
of two channels with equal SNR (Carter's bound, whose asymptotes are thesis eqs. (3.28) and
(3.29); see :mod:`.bounds`):

    σ_τ² = (1 − ρ²)/ρ² / (2 T B β²),   β² = −r''(τ̂)/r(τ̂),

T the snapshot length and B the band's width. For a white band β² B = (2π)²(f_hi³ − f_lo³)/3,
which makes this equal to the bound. It is a local (above-threshold) figure: it does not
know about the outliers below the collapse SNR of fig. 3.15.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import uniform_filter1d

from arrayproc.dsp import fft
from arrayproc.dsp.bands import band_slice

from ._kernels import (
    SINC_HALF,
    corr_at,
    cross_band,
    fill_transposed,
    predicted_peaks,
    refine_peaks,
    sinc_refine,
    windowed_peaks,
)

WEIGHTINGS = ("none", "phat", "scot", "ml")
INTERPS = ("fft", "sinc", "parabolic", "none")


@dataclass(frozen=True)
class Delays:
    """Delays of every channel relative to the reference, per snapshot.

    Attributes
    ----------
    tau : (S, n_ch) ndarray
        Delay, s (0 on the reference channel).
    sigma : (S, n_ch) ndarray
        Standard deviation of the delay, s (0 on the reference channel).
    corr : (S, n_ch) ndarray
        Normalised peak correlation (1 on the reference channel).
    """

    tau: np.ndarray
    sigma: np.ndarray
    corr: np.ndarray


class GccEstimator:
    """Planned GCC delay estimator for snapshots of ``n`` samples of ``n_ch`` channels.

    Parameters
    ----------
    n : int
        Samples per snapshot.
    fs : float
        Sample rate, Hz.
    n_ch : int
        Channels.
    reference : int
        Reference channel.
    band : (lo, hi) Hz or None
        Band of the cross-spectrum (None: all bins but DC).
    max_lag : float or (n_ch,) array or None
        Largest |τ| searched per channel, s (None: the whole snapshot, n − 1 samples).
    weighting : str
        One of ``none``, ``phat``, ``scot``, ``ml``.
    interp : str
        Sub-sample refinement: ``fft`` (maximum of the exact band-limited correlation),
        ``sinc`` (maximum of the sampled correlation interpolated by a Blackman-windowed sinc
        of ±16 samples: as exact while the band stays below about 0.4 fs, and much cheaper),
        ``parabolic`` or ``none``.
    smooth_bins : int
        Width of the moving average over bins for the ``scot`` and ``ml`` spectra.
    n_iter : int
        Newton steps of the ``fft`` refinement.
    circular : bool
        Circular correlation of the ``n`` samples (no zero padding; lags up to n/2): exact
        for periodic signals, as in a simulation that delays by a DFT phase ramp. Default
        False: the transform is padded so that the correlation is linear over the searched
        lags.
    candidates : int
        Most local maxima of the sampled correlation refined before the best is kept (those
        within the largest sampling loss of a cosine at the band's top, cos(π f_hi/fs), of the
        highest): with narrow bands the sampled peak of the right carrier cycle can sit below a
        neighbour's.
    """

    def __init__(self, n: int, fs: float, n_ch: int, reference: int = 0,
                 band: tuple[float, float] | None = None,
                 max_lag: float | np.ndarray | None = None, weighting: str = "none",
                 interp: str = "fft", smooth_bins: int = 9, n_iter: int = 6,
                 circular: bool = False, candidates: int = 16) -> None:
        if weighting not in WEIGHTINGS:
            raise ValueError(f"weighting must be one of {WEIGHTINGS}, got {weighting!r}")
        if interp not in INTERPS:
            raise ValueError(f"interp must be one of {INTERPS}, got {interp!r}")
        if not 0 <= reference < n_ch:
            raise ValueError(f"reference channel {reference} outside 0..{n_ch - 1}")
        self.n, self.fs, self.n_ch, self.reference = int(n), float(fs), int(n_ch), int(reference)
        self.weighting, self.interp = weighting, interp
        self.smooth_bins, self.n_iter = int(smooth_bins), int(n_iter)
        self.candidates = max(1, int(candidates))
        f_hi = (band[1] if band is not None else fs / 2)
        # a sampled cosine at f_hi loses at most this fraction half a sample off its crest
        self._frac = float(np.cos(np.pi * min(f_hi, fs / 2) / fs)) if self.candidates > 1 else 1.0
        longest = (n // 2 - 1 if circular else n - 1) / fs
        if max_lag is None:
            lim = np.full(n_ch, longest)
        else:
            lim = np.broadcast_to(np.asarray(max_lag, float), (n_ch,)).copy()
            lim = np.minimum(lim, longest)
        self.max_lag = lim
        self.lag_samples = np.ceil(lim * fs - 1e-9).astype(np.int64)
        # the sampled correlation is kept over the searched lags, plus the sinc's taps
        self.L = int(self.lag_samples.max()) if n_ch else 0
        self.Lw = self.L + (SINC_HALF if interp == "sinc" else 0)
        if circular:
            self.nfft = self.n
        else:  # an even length: the inverse transform returns 2 (bins − 1) samples
            self.nfft = fft.next_fast_len(self.n + self.Lw + 1)
            while self.nfft % 2:
                self.nfft = fft.next_fast_len(self.nfft + 1)
        if self.nfft % 2:
            raise ValueError(f"circular correlation needs an even snapshot length, got {n}")
        if 2 * self.Lw + 1 > self.nfft:
            raise ValueError("lag limit too long for the snapshot (lower max_lag)")
        self.k1, self.k2 = band_slice(self.nfft, fs, band)
        self.df = fs / self.nfft
        self.freqs = np.arange(self.k1, self.k2) * self.df
        self.band_width = (self.k2 - self.k1) * self.df
        self.T = self.n / fs

    # -- spectra ---------------------------------------------------------------------------
    def spectra(self, frames: np.ndarray) -> np.ndarray:
        """Band bins of the zero-padded DFTs of every channel, shape (S, n_ch, n_bins).

        Parameters
        ----------
        frames : (S, n, n_ch) array
            Snapshots, time along axis 1.
        """
        S, n, n_ch = frames.shape
        if n != self.n or n_ch != self.n_ch:
            raise ValueError(f"frames of shape {(n, n_ch)}, planned for {(self.n, self.n_ch)}")
        dtype = np.float32 if frames.dtype == np.float32 else np.float64
        plan = fft.buffered_plan("rfft", (S * n_ch, self.nfft), dtype)
        buf = plan.input.reshape(S, n_ch, self.nfft)
        if frames.dtype == buf.dtype:
            fill_transposed(frames, buf, n)
        else:
            buf[:, :, :n] = frames.transpose(0, 2, 1)
            buf[:, :, n:] = 0.0
        return plan().reshape(S, n_ch, -1)[:, :, self.k1:self.k2]

    def _weights(self, G: np.ndarray, X: np.ndarray, tau0: np.ndarray) -> np.ndarray:
        if self.weighting == "phat":
            return 1.0 / np.maximum(np.abs(G), 1e-30)
        P = (X.real**2 + X.imag**2).astype(np.float64)
        Ps = uniform_filter1d(P, self.smooth_bins, axis=-1, mode="nearest")
        Pr = Ps[:, self.reference][:, None, :]
        if self.weighting == "scot":
            return 1.0 / np.maximum(np.sqrt(Ps * Pr), 1e-30)
        rot = np.exp(-2j * np.pi * self.freqs[None, None, :] * tau0[:, :, None])
        Gd = G * rot
        Gs = (uniform_filter1d(Gd.real, self.smooth_bins, axis=-1, mode="nearest")
              + 1j * uniform_filter1d(Gd.imag, self.smooth_bins, axis=-1, mode="nearest"))
        g2 = np.clip((Gs.real**2 + Gs.imag**2) / np.maximum(Ps * Pr, 1e-300), 0.0, 0.999)
        return g2 / ((1.0 - g2) * np.maximum(np.abs(G), 1e-30))

    def _correlate(self, Gw: np.ndarray) -> np.ndarray:
        """Correlation rows at lags −Lw … Lw (samples), shape (m, 2 Lw + 1)."""
        m = Gw.shape[0]
        cdt = np.complex64 if Gw.dtype == np.complex64 else np.complex128
        plan = fft.buffered_plan("irfft", (m, self.nfft // 2 + 1), cdt)
        z = plan.input
        z[:, :self.k1] = 0.0
        z[:, self.k1:self.k2] = Gw
        z[:, self.k2:] = 0.0
        r = plan()
        L = self.Lw
        return np.concatenate([r[:, self.nfft - L:], r[:, :L + 1]], axis=1)

    # -- estimate --------------------------------------------------------------------------
    def __call__(self, frames: np.ndarray) -> Delays:
        """Delays of every channel relative to the reference in each snapshot.

        Parameters
        ----------
        frames : (S, n, n_ch) array
            Snapshots, time along axis 1 (a single (n, n_ch) snapshot is accepted too).

        Returns
        -------
        Delays
            ``tau``, ``sigma`` (s) and ``corr``, each (S, n_ch).
        """
        frames = np.asarray(frames)
        if frames.ndim == 2:
            frames = frames[None]
        X = self.spectra(frames)
        return self.from_spectra(X)

    def from_spectra(self, X: np.ndarray) -> Delays:
        """As :meth:`__call__`, from the band bins returned by :meth:`spectra`."""
        S, n_ch, nb = X.shape
        ref = self.reference
        L = self.Lw  # index of lag 0 in the correlation rows
        m = S * n_ch
        lim = np.tile(self.lag_samples, S)
        lo_i, hi_i = L - lim, L + lim
        cdt = np.complex64 if X.dtype == np.complex64 else np.complex128
        plan = fft.buffered_plan("irfft", (m, self.nfft // 2 + 1), cdt)
        z = plan.input
        E = np.empty((S, n_ch))
        if self.weighting == "none":  # the cross-spectrum goes straight into the inverse input
            G = z[:, self.k1:self.k2]
            cross_band(X, ref, G, E)
            Gw = G
        else:
            G = np.empty((m, nb), cdt)
            cross_band(X, ref, G, E)
            if self.weighting == "ml":
                r0 = self._correlate(G)
                i0 = windowed_peaks(r0, lo_i, hi_i, 1, 1.0)[0][:, 0]
                tau0 = ((i0 - L) / self.fs).reshape(S, n_ch)
            else:
                tau0 = np.zeros((S, n_ch))
            W = self._weights(G.reshape(S, n_ch, nb), X, tau0).reshape(m, nb)
            z[:, self.k1:self.k2] = G * W
            Gw = z[:, self.k1:self.k2]
        z[:, :self.k1] = 0.0
        z[:, self.k2:] = 0.0
        full = plan()
        r = np.concatenate([full[:, self.nfft - L:], full[:, :L + 1]], axis=1)
        K = 1 if self.interp == "none" else self.candidates
        idx, count = windowed_peaks(r, lo_i, hi_i, K, self._frac)
        keep = (np.arange(K)[None, :] < count[:, None]).reshape(-1)
        rows = np.repeat(np.arange(m), K)[keep]
        idx = idx.reshape(-1)[keep]
        lo_r, hi_r = lo_i[rows], hi_i[rows]
        lim_s = np.tile(self.max_lag, S)[rows]
        tau = (idx - L).astype(np.float64)
        y1 = r[rows, idx].astype(np.float64)
        peak = y1
        if self.interp != "none":
            y0 = r[rows, np.maximum(idx - 1, 0)].astype(np.float64)
            y2 = r[rows, np.minimum(idx + 1, 2 * L)].astype(np.float64)
            den = y0 - 2.0 * y1 + y2
            ok = (den < 0) & (idx > lo_r) & (idx < hi_r)
            delta = np.clip(np.where(ok, 0.5 * (y0 - y2) / np.where(ok, den, 1.0), 0.0),
                            -0.5, 0.5)
            tau = tau + delta
            peak = y1 - 0.25 * (y0 - y2) * delta
        tau = np.clip(tau / self.fs, -lim_s, lim_s)
        Gm = Gw  # rows contiguous, row stride of the inverse transform's input
        if self.interp == "fft":
            centre = (idx - L) / self.fs
            lo = np.maximum(centre - 1.0 / self.fs, -lim_s)
            hi = np.minimum(centre + 1.0 / self.fs, lim_s)
            multi = np.flatnonzero(count[rows] > 1)
            if multi.size:  # one Newton step each, then refine only the near-best candidates
                t1, pred = predicted_peaks(Gm, rows[multi], self.freqs[0], self.df, tau[multi],
                                           lo[multi], hi[multi])
                tau[multi] = t1
                top = np.full(m, -np.inf)
                np.maximum.at(top, rows[multi], pred)
                r_m = rows[multi]
                sel = np.ones(rows.size, bool)
                sel[multi] = pred >= top[r_m] - 0.02 * np.abs(top[r_m])
                rows, tau, lo, hi = rows[sel], tau[sel], lo[sel], hi[sel]
            tau, peak, peak2 = refine_peaks(Gm, rows, self.freqs[0], self.df, tau, lo, hi,
                                            self.n_iter, 1e-7 / self.fs)
        elif self.interp == "sinc":
            x, peak, peak2 = sinc_refine(r, rows, tau * self.fs + L,
                                         np.maximum(idx - 1.0, L - lim_s * self.fs),
                                         np.minimum(idx + 1.0, L + lim_s * self.fs),
                                         self.n_iter, 1e-7)
            tau = (x - L) / self.fs
            # irfft rows are (2/N) Re Σ G e^{j2πfτ}; derivatives per sample² → per s²
            peak = peak * (self.nfft / 2)
            peak2 = peak2 * (self.nfft / 2) * self.fs**2
        # the highest refined candidate of each row (rows are in order in ``rows``)
        order = np.lexsort((-peak, rows))
        first = np.r_[0, np.flatnonzero(np.diff(rows[order])) + 1]
        best = order[first]
        tau = tau[best]
        if self.interp in ("fft", "sinc") and self.weighting == "none":  # r, r'' known there
            ru, ru2 = peak[best], peak2[best]
        else:
            ru, ru2 = corr_at(G.reshape(m, nb), self.freqs[0], self.df,
                              np.ascontiguousarray(tau))
        norm = np.sqrt(np.maximum(E * E[:, ref][:, None], 1e-300)).reshape(-1)
        rho = ru / norm
        tau = tau.reshape(S, n_ch)
        corr = rho.reshape(S, n_ch)
        sigma = delay_sigma(rho, ru, ru2, self.T, self.band_width).reshape(S, n_ch)
        tau[:, ref] = 0.0
        sigma[:, ref] = 0.0
        corr[:, ref] = 1.0
        return Delays(tau, sigma, corr)


def delay_sigma(rho: np.ndarray, r: np.ndarray, r2: np.ndarray, T: float,
                band_width: float) -> np.ndarray:
    """Standard deviation of a correlation-peak delay from its curvature and height.

    Parameters
    ----------
    rho : array
        Normalised peak correlation, read as the coherence S/(S+N) of the two channels.
    r, r2 : array
        Plain correlation and its second derivative (s⁻²) at the peak.
    T : float
        Snapshot length, s.
    band_width : float
        Width of the band used, Hz.

    Returns
    -------
    array
        σ_τ, s: √((1 − ρ²)/ρ² / (2 T B β²)) with β² = −r''/r (see the module docstring);
        infinite where ρ ≤ 0 or the peak is not a maximum.
    """
    rho = np.clip(np.asarray(rho, float), 1e-12, 1.0 - 1e-12)
    with np.errstate(divide="ignore", invalid="ignore"):
        beta2 = -np.asarray(r2, float) / np.asarray(r, float)
        var = (1.0 - rho**2) / rho**2 / (2.0 * T * band_width * beta2)
    bad = ~(np.isfinite(var) & (var > 0) & (np.asarray(r) > 0))
    return np.where(bad, np.inf, np.sqrt(np.where(bad, 1.0, var)))


def gcc_delays(frames: np.ndarray, fs: float, reference: int = 0,
               band: tuple[float, float] | None = None,
               max_lag: float | np.ndarray | None = None, weighting: str = "none",
               interp: str = "fft", smooth_bins: int = 9) -> Delays:
    """One-call form of :class:`GccEstimator` (plans on every call).

    Parameters
    ----------
    frames : (S, n, n_ch) or (n, n_ch) array
        Snapshots, time along the first (single snapshot) or second axis.
    fs : float
        Sample rate, Hz.
    reference, band, max_lag, weighting, interp, smooth_bins
        As :class:`GccEstimator` (band in Hz, max_lag in s).

    Returns
    -------
    Delays
        ``tau``, ``sigma`` in s and ``corr``, each (S, n_ch).
    """
    frames = np.asarray(frames)
    if frames.ndim == 2:
        frames = frames[None]
    est = GccEstimator(frames.shape[1], fs, frames.shape[2], reference, band, max_lag,
                       weighting, interp, smooth_bins)
    return est(frames)
