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

from arrayproc.errors import ConfigError
from arrayproc.geo.beams import beam_count

from . import _kernels as K
from .bank import BandPlan


def beam_axis(beams: dict) -> tuple[np.ndarray, np.ndarray, str]:
    """Parse a ``beams`` table.

    Parameters
    ----------
    beams : dict
        ``{start, stop, count}`` (cone angles, deg) or ``{bearings, elevations}`` (deg).

    Returns
    -------
    axis : ndarray
        Cone angles (B,) deg, or (B, 2) [bearing, elevation] deg.
    dirs : (B, 3) ndarray
        Body-frame unit vectors towards the beam (cone beams: only x = cos(cone) used).
    mode : {"cone", "3d"}
    """
    keys = set(beams)
    if {"start", "stop", "count"} <= keys <= {"start", "stop", "count"}:
        try:
            a, b, n = float(beams["start"]), float(beams["stop"]), beam_count(beams["count"])
        except (TypeError, ValueError):
            raise ConfigError("key 'beams': start, stop must be numbers and count an "
                              "integer") from None
        if n < 1 or not (0 <= a <= 180 and 0 <= b <= 180):
            raise ConfigError("key 'beams': cone angles in [0, 180] deg and count >= 1")
        cone = np.linspace(a, b, n)
        dirs = np.zeros((n, 3))
        dirs[:, 0] = np.cos(np.deg2rad(cone))
        return cone, dirs, "cone"
    if "bearings" in keys and keys <= {"bearings", "elevations"}:
        try:
            brg = np.asarray(beams["bearings"], float).reshape(-1)
            elv = np.asarray(beams.get("elevations", [0.0]), float).reshape(-1)
        except (TypeError, ValueError):
            raise ConfigError("key 'beams': bearings and elevations must be lists of "
                              "numbers") from None
        if brg.size == 0 or elv.size == 0 or np.any(np.abs(elv) > 90):
            raise ConfigError("key 'beams': need bearings and elevations in [-90, 90] deg")
        e, b = np.meshgrid(np.deg2rad(elv), np.deg2rad(brg), indexing="ij")
        e, b = e.ravel(), b.ravel()
        dirs = np.stack([np.cos(e) * np.cos(b), np.cos(e) * np.sin(b), -np.sin(e)], -1)
        return np.stack([np.rad2deg(b), np.rad2deg(e)], -1), dirs, "3d"
    raise ConfigError("key 'beams': expected {start, stop, count} (cone angles, deg) or "
                      "{bearings = [...], elevations = [...]} (deg)")


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
