"""Closed-form beam pattern of a uniform line array (thesis eq. (2.13)).

The reference the conventional beamformer is tested against: with unit shading, a plane wave
from θ0 gives a beam output proportional to I_NH(θ, θ0, f).
"""

from __future__ import annotations

import numpy as np

__all__ = ["line_array_pattern"]


def line_array_pattern(theta_deg: np.ndarray, theta0_deg: float, freq: float, n: int,
                       spacing: float, c: float = 1500.0) -> np.ndarray:
    """Array factor I_NH(θ, θ0, f) = (1 − e^{jψN}) / (1 − e^{jψ}) (thesis eq. (2.13)).

    ψ = 2π f δx / c (cos θ − cos θ0); where ψ → 0 the limit N_H is returned.

    Parameters
    ----------
    theta_deg : array
        Steering cone angles θ, deg.
    theta0_deg : float
        Cone angle of the plane wave θ0, deg.
    freq : float
        Frequency, Hz.
    n : int
        Hydrophones N_H.
    spacing : float
        Spacing δx, m.
    c : float
        Sound speed, m/s.

    Returns
    -------
    complex ndarray, shape of ``theta_deg``
        |I_NH|² is the power pattern, N_H² on the main-lobe axis.
    """
    th = np.asarray(theta_deg, float)
    psi = 2 * np.pi * freq * spacing / c * (np.cos(np.deg2rad(th)) - np.cos(np.deg2rad(theta0_deg)))
    out = np.full(psi.shape, complex(n))
    m = np.abs(np.exp(1j * psi) - 1) > 1e-12
    out[m] = (1 - np.exp(1j * psi[m] * n)) / (1 - np.exp(1j * psi[m]))
    return out
