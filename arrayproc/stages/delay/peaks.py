"""The K strongest cross-correlation peaks of every hydrophone pair (several sources at once).

With one source the correlation of channels a and b has one peak, at the delay
τ_ab = τ_b − τ_a of b after a (thesis eq. (3.26)); with several simultaneous sources it has one
peak per source (where the sources do not overlap in lag). For every pair a < b of the array,
every snapshot,

    r_ab(τ) = DFT⁻¹( W_k X_b,k X_a,k* ),   k over the band's bins (eq. (3.27)),

is computed in one batch (the spectra of :meth:`.gcc.GccEstimator.spectra`, one batch of
inverse FFTs over all pairs and snapshots), its local maxima inside the physical window
|τ_ab| ≤ |p_a − p_b|/c + margin found by :func:`._kernels.windowed_peaks`, every candidate
refined to the maximum of the band-limited correlation (:func:`._kernels.refine_peaks`, the
``interp = "fft"`` refinement of :mod:`.gcc`; a maximum that ends on the window's edge is
the slope of a peak outside it and is dropped), and of the refined maxima the ``k`` highest
lying at least ``min_sep`` apart are kept (:func:`._kernels.distinct_peaks`; by default
``min_sep`` = 1/B, the width of the correlation's main lobe for a band of width B, so the
carrier cycles of one source's peak are not taken for other sources). Each kept peak has
ρ = r(τ̂)/√(E_a E_b) of the plain correlation, its σ by :func:`.gcc.delay_sigma` and its SNR
read from ρ as a coherence, SNR = ρ/(1 − ρ) (:mod:`.bounds`).

Weightings ``none``, ``phat`` and ``scot`` (Knapp & Carter 1976, as :mod:`.gcc`); the ML weight
needs a first delay per pair and a single source, and is refused here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import uniform_filter1d

from arrayproc.dsp import fft

from ._kernels import distinct_peaks, refine_peaks, windowed_peaks
from .gcc import GccEstimator, delay_sigma

#: weightings of the pair search (the ML weight is single-source)
PAIR_WEIGHTINGS = ("none", "phat", "scot")


def all_pairs(n_ch: int) -> np.ndarray:
    """Every channel pair (a, b), a < b, in lexicographic order, shape (n_ch (n_ch − 1)/2, 2)."""
    a, b = np.triu_indices(n_ch, 1)
    return np.stack([a, b], axis=1).astype(np.int64)


@dataclass(frozen=True)
class PairPeaks:
    """The kept peaks of every pair, per snapshot (NaN where a pair has fewer than k).

    Attributes
    ----------
    pairs : (P, 2) int64
        Channel pairs (a, b); the lag is b's delay after a.
    tau, sigma : (S, P, k) ndarray
        Lag and its σ, s.
    corr : (S, P, k) ndarray
        Normalised peak of the plain correlation.
    snr_db : (S, P, k) ndarray
        SNR read from ``corr`` as a coherence, 10 log10(ρ/(1 − ρ)), dB.
    """

    pairs: np.ndarray
    tau: np.ndarray
    sigma: np.ndarray
    corr: np.ndarray
    snr_db: np.ndarray


def coherence_snr_db(rho: np.ndarray) -> np.ndarray:
    """SNR of two channels with equal SNR from their coherence ρ = S/(S + N): 10 log10(ρ/(1 − ρ))
    dB (−inf for ρ ≤ 0)."""
    r = np.clip(np.asarray(rho, float), 0.0, 1.0 - 1e-12)
    with np.errstate(divide="ignore"):
        return 10.0 * np.log10(r / (1.0 - r))


class PairPeakEstimator:
    """Planned K-peak search over every pair of ``n_ch`` channels (see the module docstring).

    Parameters
    ----------
    n : int
        Samples per snapshot.
    fs : float
        Sample rate, Hz.
    pair_lag : (P,) array
        Largest |τ| searched per pair of ``pairs``, s.
    pairs : (P, 2) int array
        Channel pairs (a, b).
    n_ch : int
        Channels.
    band : (lo, hi) Hz or None
        Band of the cross-spectra.
    k : int
        Peaks kept per pair.
    weighting : str
        ``none``, ``phat`` or ``scot``.
    min_sep : float or None
        Smallest lag between two kept peaks of a pair, s (None: 1/B).
    smooth_bins, n_iter : int
        As :class:`.gcc.GccEstimator`.
    candidates : int
        Local maxima refined per pair before the ``k`` distinct highest are kept.
    """

    def __init__(self, n: int, fs: float, pair_lag: np.ndarray, pairs: np.ndarray, n_ch: int,
                 band: tuple[float, float] | None = None, k: int = 3,
                 weighting: str = "none", min_sep: float | None = None, smooth_bins: int = 9,
                 n_iter: int = 6, candidates: int = 16) -> None:
        if weighting not in PAIR_WEIGHTINGS:
            raise ValueError(f"weighting must be one of {PAIR_WEIGHTINGS} for several peaks, "
                             f"got {weighting!r}")
        if k < 1:
            raise ValueError(f"k must be >= 1, got {k}")
        self.pairs = np.asarray(pairs, np.int64).reshape(-1, 2)
        lag = np.broadcast_to(np.asarray(pair_lag, float), (self.pairs.shape[0],))
        # the spectra plan of the longest pair: one transform length for all pairs
        self.gcc = GccEstimator(n, fs, n_ch, 0, band, float(lag.max()) if lag.size else 0.0,
                                "none", "fft", smooth_bins, n_iter)
        g = self.gcc
        self.max_lag = np.minimum(lag, (n - 1) / fs)
        self.lag_samples = np.ceil(self.max_lag * fs - 1e-9).astype(np.int64)
        self.k, self.weighting, self.smooth_bins, self.n_iter = int(k), weighting, \
            int(smooth_bins), int(n_iter)
        self.candidates = max(int(candidates), 4 * self.k)
        self.min_sep = float(min_sep) if min_sep is not None else 1.0 / max(g.band_width, 1e-9)

    def __call__(self, frames: np.ndarray) -> PairPeaks:
        """Peaks of every pair in each snapshot of ``frames`` (S, n, n_ch) (or (n, n_ch))."""
        frames = np.asarray(frames)
        if frames.ndim == 2:
            frames = frames[None]
        return self.from_spectra(self.gcc.spectra(frames))

    def _weighted(self, G: np.ndarray, X: np.ndarray) -> np.ndarray:
        if self.weighting == "none":
            return G
        if self.weighting == "phat":
            return G / np.maximum(np.abs(G), 1e-30)
        P = (X.real**2 + X.imag**2).astype(np.float64)
        Ps = uniform_filter1d(P, self.smooth_bins, axis=-1, mode="nearest")
        a, b = self.pairs[:, 0], self.pairs[:, 1]
        return G / np.maximum(np.sqrt(Ps[:, a] * Ps[:, b]), 1e-30)

    def from_spectra(self, X: np.ndarray) -> PairPeaks:
        """As :meth:`__call__`, from the band bins of :meth:`.gcc.GccEstimator.spectra`."""
        g = self.gcc
        S, n_ch, nb = X.shape
        P, K = self.pairs.shape[0], self.k
        a, b = self.pairs[:, 0], self.pairs[:, 1]
        m = S * P
        cdt = np.complex64 if X.dtype == np.complex64 else np.complex128
        G = np.ascontiguousarray((X[:, b] * np.conj(X[:, a])).reshape(m, nb).astype(cdt))
        E = np.einsum("scf,scf->sc", X.real.astype(float), X.real.astype(float)) \
            + np.einsum("scf,scf->sc", X.imag.astype(float), X.imag.astype(float))
        Gw = np.ascontiguousarray(self._weighted(G.reshape(S, P, nb), X).reshape(m, nb)
                                  .astype(cdt))
        L = g.Lw
        plan = fft.buffered_plan("irfft", (m, g.nfft // 2 + 1), cdt)
        z = plan.input
        z[:, :g.k1] = 0.0
        z[:, g.k1:g.k2] = Gw
        z[:, g.k2:] = 0.0
        full = plan()
        r = np.concatenate([full[:, g.nfft - L:], full[:, :L + 1]], axis=1)
        lim = np.tile(self.lag_samples, S)
        lo_i, hi_i = L - lim, L + lim
        C = self.candidates
        idx, count = windowed_peaks(r, lo_i, hi_i, C, 0.0)
        keep = np.arange(C)[None, :] < count[:, None]
        rows = np.repeat(np.arange(m), C)
        lim_s = np.tile(self.max_lag, S)[rows]
        centre = (idx.reshape(-1) - L) / g.fs
        lo = np.maximum(centre - 1.0 / g.fs, -lim_s)
        hi = np.minimum(centre + 1.0 / g.fs, lim_s)
        tau, h, _ = refine_peaks(Gw, rows, g.freqs[0], g.df, np.clip(centre, lo, hi), lo, hi,
                                 self.n_iter, 1e-7 / g.fs)
        tau, h = tau.reshape(m, C), h.reshape(m, C)
        # a maximum on the window's edge is the slope of a peak outside it, not a source
        edge = np.abs(tau) >= lim_s.reshape(m, C) - 1e-3 / g.fs
        ok = keep & (h > 0) & np.isfinite(tau) & ~edge
        sel = distinct_peaks(tau, h, ok, K, self.min_sep)
        got = sel >= 0
        rr = np.repeat(np.arange(m), K)[got.reshape(-1)]
        t_k = np.take_along_axis(tau, np.maximum(sel, 0), axis=1).reshape(-1)[got.reshape(-1)]
        # the plain correlation and its curvature there (no Newton step: n_iter = 0)
        _, ru, ru2 = refine_peaks(G, rr, g.freqs[0], g.df, t_k, t_k, t_k, 0, 0.0)
        Ea = E[:, a].reshape(-1)[rr]
        Eb = E[:, b].reshape(-1)[rr]
        rho = ru / np.sqrt(np.maximum(Ea * Eb, 1e-300))
        sig = delay_sigma(rho, ru, ru2, g.T, g.band_width)
        out = {k: np.full(m * K, np.nan) for k in ("tau", "sigma", "corr")}
        flat = got.reshape(-1)
        out["tau"][flat], out["sigma"][flat], out["corr"][flat] = t_k, sig, rho
        tau_o, sig_o, corr_o = (out[k].reshape(S, P, K) for k in ("tau", "sigma", "corr"))
        return PairPeaks(self.pairs, tau_o, sig_o, corr_o, coherence_snr_db(corr_o))
