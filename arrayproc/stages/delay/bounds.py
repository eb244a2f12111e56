"""Lower bounds on the standard deviation of a time-delay estimate (thesis eqs. (3.28), (3.29)).

Two channels receive a common white signal over [f_min, f_max] in independent white noise, the
signal-to-noise ratio (ratio of power spectral densities in the band) ``SNR`` on each, observed
for ``T`` seconds. Quazi's asymptotes, quoted by the thesis (and as eqs. (C.1), (C.2)):

    low SNR  (3.28):  σ_τ = (1/SNR) √( 3 / (8π² T (f_max³ − f_min³)) )
    high SNR (3.29):  σ_τ = √( 3 / (4 SNR π² T (f_max³ − f_min³)) )

Both are limits of the Cramér-Rao bound of Hannan-Thomson / Carter for coherence
γ = SNR/(1 + SNR),

    σ_τ² = [ 2T ∫ (2πf)² γ²/(1 − γ²) df ]⁻¹ = 3 (1 + 2 SNR) / (8π² T SNR² (f_max³ − f_min³)),

which :func:`crlb` returns (it tends to (3.28) as SNR → 0 and to (3.29) as SNR → ∞).
"""

from __future__ import annotations

import numpy as np


def _cube(f_min: float, f_max: float) -> float:
    if not 0 <= f_min < f_max:
        raise ValueError(f"need 0 <= f_min < f_max, got {f_min}, {f_max}")
    return f_max**3 - f_min**3


def quazi_low(snr: np.ndarray | float, T: float, f_min: float, f_max: float) -> np.ndarray:
    """Low-SNR bound, thesis eq. (3.28).

    Parameters
    ----------
    snr : float or array
        Signal-to-noise ratio per channel (linear, PSD ratio in the band).
    T : float
        Observation time, s.
    f_min, f_max : float
        Band, Hz.

    Returns
    -------
    ndarray
        σ_τ, s.
    """
    return np.sqrt(3.0 / (8 * np.pi**2 * T * _cube(f_min, f_max))) / np.asarray(snr, float)


def quazi_high(snr: np.ndarray | float, T: float, f_min: float, f_max: float) -> np.ndarray:
    """High-SNR bound, thesis eq. (3.29). Parameters and return as :func:`quazi_low`."""
    return np.sqrt(3.0 / (4 * np.asarray(snr, float) * np.pi**2 * T * _cube(f_min, f_max)))


def crlb(snr: np.ndarray | float, T: float, f_min: float, f_max: float) -> np.ndarray:
    """Cramér-Rao bound for any SNR (see the module docstring); its asymptotes are
    :func:`quazi_low` and :func:`quazi_high`. Parameters and return as :func:`quazi_low`."""
    s = np.asarray(snr, float)
    return np.sqrt(3.0 * (1.0 + 2.0 * s) / (8 * np.pi**2 * T * s**2 * _cube(f_min, f_max)))


def arrival_variance(snr: np.ndarray | float, T: float, f_min: float, f_max: float
                     ) -> np.ndarray:
    """Each channel's share of the delay bound, for channels of unequal SNR.

    A pair's bound splits into one share per channel, σ_ab² = v_a + v_b with

        v_i = 3 (1 + 1/(2 SNR_i)) / (8π² T SNR_i (f_max³ − f_min³)),

    exact (σ² = :func:`crlb`²) for equal SNRs and tending to the bound of the pair's coherence
    γ² = SNR_a SNR_b/((1 + SNR_a)(1 + SNR_b)) at high SNR. Delays against one reference share
    its v_ref (:func:`arrayproc.geo.tdoa.arrival_covariance`): the bound of one source's
    delays when every channel has its own SNR (the other sources counted as absent).

    Parameters
    ----------
    snr : float or array
        Per-channel SNR (linear, in-band PSD ratio).
    T : float
        Observation time, s.
    f_min, f_max : float
        Band, Hz.

    Returns
    -------
    ndarray
        v_i, s².
    """
    s = np.asarray(snr, float)
    return 3.0 * (1.0 + 0.5 / s) / (8 * np.pi**2 * T * s * _cube(f_min, f_max))
