"""Amplitude and noise estimation for the narrowband EKF (thesis 3.2.1.3).

The thesis estimates the tonal's amplitude from "the magnitude of the analytic representation
of the signal" and divides it out before the Kalman filter, whose model (eq. (3.21)) has unit
amplitude. The envelope alone also carries the noise, which at the hydrophone SNRs of
figs. 3.8-3.9 is as strong as the tonal, so here the envelope power is split into the tonal and
the noise with the array: a plane wave adds coherently over the N elements when steered at the
current (θ, f) estimate, the noise does not. With ``z`` the analytic (or baseband) samples,
``P_e = mean |z_n|²`` and ``P_b = mean |Σ_n z_n w_n / N|²`` (``w_n`` the conjugate model
phases)::

    E P_e = A² + σ_z²,   E P_b = A² + σ_z² / N
    ⇒ σ_z² = N (P_e − P_b) / (N − 1),   A² = P_e − σ_z².

For real input σ_z² = 2 σ² (σ² the real noise variance); for baseband input σ_z² = E|v|².
Written by hand (a two-line moment estimator).
"""

from __future__ import annotations

import numpy as np
from scipy.signal import hilbert


def analytic(y: np.ndarray) -> np.ndarray:
    """Analytic signal along axis 0 of a real (T, N) series; complex input is returned as is."""
    return y if np.iscomplexobj(y) else hilbert(y, axis=0)


def split_power(z: np.ndarray, steer: np.ndarray) -> tuple[float, float]:
    """Tonal power A² and noise power σ_z² of analytic/baseband samples.

    Parameters
    ----------
    z : (T, N) complex ndarray
        Analytic (or baseband) element samples, input units.
    steer : (N,) complex ndarray
        Unit-modulus steering weights that align the tonal's phase across the elements.

    Returns
    -------
    a2 : float
        Tonal power A² (input units²), floored at 1e-6 P_e.
    noise : float
        Noise power σ_z² = E|v_n|² of the analytic/baseband samples (input units²).
    """
    n = z.shape[1]
    pe = float(np.mean(np.abs(z) ** 2))
    pb = float(np.mean(np.abs(z @ steer / n) ** 2))
    s2 = max(n * (pe - pb) / (n - 1), 0.0)
    a2 = max(pe - s2, 1e-6 * pe)
    return a2, s2
