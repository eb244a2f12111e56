"""Time delays from the slope of the cross-spectrum phase (thesis eqs. (3.30)-(3.36), app. B).

The cross-spectrum of channel ``i`` and the reference over the band, eq. (3.30), has the phase
(with numpy's DFT sign, X = Σ x e^{-j2πft}, so a later arrival turns the phase negative)

    φ_l = φ_0 − 2π f_l τ + ε_l,                                                (3.31), (3.32)

and the linear least-squares fit of φ against f over the band's N bins gives, eqs. (3.33)-(3.36),

    τ̂ = −Σ (f_l − f̄)(φ_l − φ̄) / (2π Σ (f_l − f̄)²),   φ̂_0 = φ̄ + 2π f̄ τ̂.

(The thesis prints (3.33) with the factor 2π f_l outside the sum and without the (f_l − f̄)
inside; the line above is the least-squares slope the text describes.)

The phase is known only modulo 2π. It is first unwrapped by the standard rule (numpy.unwrap,
the Matlab ``unwrap`` of the thesis); appendix B then removes the 2π errors that remain:

(a) fit the line and form the residues ε̂_l = φ_l − φ̂_0 + 2π f_l τ̂, eq. (B.1);
(b) while their mean square exceeds ``threshold``², fit lines on sliding windows of ``window``
    bins and take the window with the largest local residual sum: the unwrapping error is there;
(c) add or subtract 2π to the phase at and after the bin of that window where doing so lowers
    the global residual sum the most (evaluated in closed form with prefix sums);
(d) repeat (b)-(c) while the sum falls, at most ``max_iter`` times.

The threshold of step (d) is "determined by experimenting" in the thesis; here it is a parameter
(default 0.5 rad RMS). σ_τ is the least-squares standard deviation of the slope from the residual
variance. No maintained library implements this estimator; it is written here by hand.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.fft as sfft

from arrayproc.dsp.bands import band_slice

from .gcc import Delays


def lls_delay(phase: np.ndarray, freqs: np.ndarray) -> tuple[float, float, float]:
    """Least-squares line through the unwrapped phase, thesis eqs. (3.33)-(3.36).

    Parameters
    ----------
    phase : (N,) array
        Unwrapped cross-spectrum phase, rad.
    freqs : (N,) array
        Bin frequencies, Hz.

    Returns
    -------
    tau : float
        Delay, s (−slope / 2π).
    phi0 : float
        Intercept, rad.
    ssr : float
        Sum of squared residues (B.1), rad².
    """
    fbar = freqs.mean()
    pbar = phase.mean()
    df = freqs - fbar
    slope = float(np.dot(df, phase - pbar) / np.dot(df, df))
    phi0 = pbar - slope * fbar
    res = phase - phi0 - slope * freqs
    return -slope / (2 * np.pi), float(phi0), float(np.dot(res, res))


def _ssr_after_step(phase: np.ndarray, freqs: np.ndarray, lo: int, hi: int) -> tuple[np.ndarray,
                                                                                       np.ndarray]:
    """Residual sums of the LLS line after adding ±2π to phase[j:], for every j in [lo, hi).

    Closed form: with H_j the step indicator, the fitted line's SSR of φ + a H_j is
    Syy' − (Sfy')²/Sff where the centred sums change by prefix sums over j:.
    """
    n = phase.size
    f = freqs - freqs.mean()
    y = phase - phase.mean()
    sff = np.dot(f, f)
    sfy = np.dot(f, y)
    syy = np.dot(y, y)
    j = np.arange(lo, hi)
    cnt = (n - j).astype(float)  # bins at and after j
    tail_f = np.cumsum(f[::-1])[::-1][j]  # Σ_{l>=j} f_l (centred)
    tail_y = np.cumsum(y[::-1])[::-1][j]
    out = []
    for a in (2 * np.pi, -2 * np.pi):
        # centred step: a(H_j − cnt/n)
        sfy_n = sfy + a * tail_f
        syy_n = syy + 2 * a * (tail_y) + a * a * cnt * (1 - cnt / n)
        out.append(syy_n - sfy_n**2 / sff)
    return out[0], out[1]


def unwrap_residues(phase: np.ndarray, freqs: np.ndarray, threshold: float = 0.5,
                    window: int = 16, max_iter: int = 20) -> tuple[np.ndarray, int]:
    """Appendix B: remove the 2π errors left in an unwrapped phase (see the module docstring).

    Parameters
    ----------
    phase : (N,) array
        Phase already unwrapped by the standard rule, rad.
    freqs : (N,) array
        Bin frequencies, Hz.
    threshold : float
        Residual RMS (rad) under which the phase is accepted.
    window : int
        Bins of the sliding local fits.
    max_iter : int
        Largest number of 2π corrections.

    Returns
    -------
    phase : (N,) ndarray
        Corrected phase, rad.
    n_fixes : int
        Corrections made.
    """
    phase = np.array(phase, dtype=float)
    n = phase.size
    w = max(3, min(int(window), n))
    fixes = 0
    _, _, ssr = lls_delay(phase, freqs)
    while fixes < max_iter and ssr / n > threshold**2:
        # (b) local residues on sliding windows: SSR of a line fitted in each window
        fw = np.lib.stride_tricks.sliding_window_view(freqs, w)
        pw = np.lib.stride_tricks.sliding_window_view(phase, w)
        fc = fw - fw.mean(axis=1, keepdims=True)
        pc = pw - pw.mean(axis=1, keepdims=True)
        local = (pc**2).sum(1) - (fc * pc).sum(1) ** 2 / (fc**2).sum(1)
        k = int(np.argmax(local))
        lo, hi = max(1, k), min(n, k + w)
        if hi <= lo:
            break
        # (c) the step position and sign within that window that lowers the global SSR most
        plus, minus = _ssr_after_step(phase, freqs, lo, hi)
        ip, im = int(np.argmin(plus)), int(np.argmin(minus))
        if plus[ip] <= minus[im]:
            best, j, a = plus[ip], lo + ip, 2 * np.pi
        else:
            best, j, a = minus[im], lo + im, -2 * np.pi
        if not best < ssr * (1 - 1e-9):
            break  # (d) no correction lowers the residues any more
        phase[j:] += a
        ssr = best
        fixes += 1
    return phase, fixes


@dataclass
class UnwrapEstimator:
    """Phase-unwrapping LLS delays of every channel relative to ``reference`` (no zero padding:
    the DFT spans the integration time T, as in the thesis).

    Parameters
    ----------
    n : int
        Samples per snapshot.
    fs : float
        Sample rate, Hz.
    reference : int
        Reference channel.
    band : (lo, hi) Hz
        Band of the fit.
    threshold, window, max_iter
        As :func:`unwrap_residues`.
    max_lag : float or (n_ch,) array or None
        Delays beyond ±max_lag (s) are clipped to it.
    """

    n: int
    fs: float
    reference: int = 0
    band: tuple[float, float] | None = None
    threshold: float = 0.5
    window: int = 16
    max_iter: int = 20
    max_lag: float | np.ndarray | None = None

    def __post_init__(self) -> None:
        self.k1, self.k2 = band_slice(self.n, self.fs, self.band)
        self.freqs = np.arange(self.k1, self.k2) * self.fs / self.n

    def __call__(self, frames: np.ndarray) -> Delays:
        """Delays, σ (s) and normalised correlation per snapshot and channel.

        Parameters
        ----------
        frames : (S, n, n_ch) or (n, n_ch) array
            Snapshots, time along axis 1.

        Returns
        -------
        Delays
            Each field (S, n_ch).
        """
        frames = np.asarray(frames, dtype=np.float64)
        if frames.ndim == 2:
            frames = frames[None]
        S, n, n_ch = frames.shape
        X = sfft.rfft(frames, axis=1)[:, self.k1:self.k2, :]
        G = X * np.conj(X[:, :, self.reference])[:, :, None]
        E = (np.abs(X) ** 2).sum(axis=1)
        tau = np.zeros((S, n_ch))
        sigma = np.zeros((S, n_ch))
        corr = np.ones((S, n_ch))
        f = self.freqs
        sff = np.dot(f - f.mean(), f - f.mean())
        dof = max(1, f.size - 2)
        lim = None if self.max_lag is None else np.broadcast_to(
            np.asarray(self.max_lag, float), (n_ch,))
        for s in range(S):
            for c in range(n_ch):
                if c == self.reference:
                    continue
                ph = np.unwrap(np.angle(G[s, :, c]))
                ph, _ = unwrap_residues(ph, f, self.threshold, self.window, self.max_iter)
                t, _, ssr = lls_delay(ph, f)
                if lim is not None:
                    t = float(np.clip(t, -lim[c], lim[c]))
                tau[s, c] = t
                sigma[s, c] = np.sqrt(ssr / dof / sff) / (2 * np.pi)
                r = np.real(np.sum(G[s, :, c] * np.exp(2j * np.pi * f * t)))
                corr[s, c] = r / np.sqrt(max(E[s, c] * E[s, self.reference], 1e-300))
        return Delays(tau, sigma, corr)
