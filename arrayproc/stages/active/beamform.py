"""Beam time series of a ping's receive window: frequency-domain delay-and-sum (thesis eq.
(2.8)) of the whole window at once, kept as complex baseband at a decimated rate.

The window (``n_fft`` samples from the transmission, zero-padded past the recording's end) is
transformed once per hydrophone; only the bins of the waveform's band are kept
(:class:`arrayproc.stages.active.bank.BandPlan`), steered exactly per bin,

    Y_b(f_k) = sum_n w_n X_n(f_k) exp(-2j pi f_k tau_n(b)),   tau_n(b) = (r_n - r_mean) . u_b / c,

(the sign and delay conventions of the ``cbf`` stage: u_b the unit vector towards the source,
tau the element's advance) and brought back to the time domain by an inverse FFT over the
K kept bins: complex baseband at ``fs_bb = K fs / n_fft`` whose sample j is at time
``t_ping + j / fs_bb``. A window as long as the ping interval makes the correlation's lags
exact (no overlap-save seams).

Beams: ``{start, stop, count}`` cone angles (deg, 0 forward end-fire; only the body-x
projection of the elements enters) or ``{bearings = [...], elevations = [...]}`` (deg,
relative to the array's forward axis, clockwise seen from above; elevation up).
"""

from __future__ import annotations

import numpy as np
import scipy.fft as sfft

from arrayproc.geo.beams import beam_directions as beam_axis  # noqa: F401  (one beams table)

from . import _kernels as K
from .bank import BandPlan


def element_advances(positions: np.ndarray, dirs: np.ndarray, mode: str,
                     c: float) -> np.ndarray:
    """Plane-wave advances tau (B, C), s, of each element over the centroid per beam."""
    rel = np.asarray(positions, float) - np.asarray(positions, float).mean(axis=0)
    if mode == "cone":
        rel = rel.copy()
        rel[:, 1:] = 0.0
    return (np.asarray(dirs, float) @ rel.T) / c


def ping_spectra(x: np.ndarray, plan: BandPlan, workers: int = 1) -> np.ndarray:
    """Band bins (C, K) complex128 of a receive window x (n, C) (zero-padded to n_fft)."""
    spec = sfft.rfft(np.asarray(x, np.float64), n=plan.n_fft, axis=0, workers=workers)
    return np.ascontiguousarray(spec[plan.k0:plan.k0 + plan.n_bins].T)


def beam_series(x: np.ndarray, plan: BandPlan, tau: np.ndarray, weights: np.ndarray,
                workers: int = 1) -> np.ndarray:
    """Complex baseband beam series (B, K) complex64 of a receive window x (n, C).

    Parameters
    ----------
    x : (n, C) ndarray
        Hydrophone samples from the transmission time on, Pa.
    plan : BandPlan
        FFT size and kept bins.
    tau : (B, C) ndarray
        Element advances, s (:func:`element_advances`).
    weights : (C,) ndarray
        Shading, mean 1.
    workers : int
        FFT threads.

    Returns
    -------
    (B, K) complex64
        Sample j at time j / fs_bb after the transmission (the analytic signal of the
        band-limited beam, shifted down by f0, times 1/n_fft: only ratios matter downstream).
    """
    xs = ping_spectra(x, plan, workers)
    y = np.empty((tau.shape[0], plan.n_bins), np.complex64)
    K.steer_bins(xs, plan.f0, plan.df, np.ascontiguousarray(tau, np.float64),
                 np.asarray(weights, np.float64), y)
    return sfft.ifft(y, axis=1, overwrite_x=True, workers=workers).astype(np.complex64)
