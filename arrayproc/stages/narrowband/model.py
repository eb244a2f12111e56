"""Measurement model of the narrowband EKF (thesis 3.2.1, eqs. (3.18)-(3.23)), in numpy.

A line array of ``N_H`` elements at body-frame positions ``x_n`` (m, forward positive) moving
forward at speed ``U`` receives a tonal of frequency ``f`` (Hz, as a stationary receiver would
hear it) from cone angle ``θ`` (rad, 0 forward end-fire). With ``τ`` the time since the filter's
(re)initialisation (s), the phase at element n is (thesis eq. (3.18), the hydrophone index term
``δx (n − 1)`` generalised to the element's position ``x_n``)::

    a   = 1 + U cos θ / c                 own-speed Doppler factor
    b   = a  (thesis eq. (3.18))   or   1  (``spatial_doppler = False``)
    u_n = a τ + b x_n cos θ / c
    Φ_n = 2π f u_n

Eq. (3.18) multiplies the element delay term by the Doppler factor too (b = a). For a plane
wave of water-frame frequency f received by elements moving at U, the exact phase is
2π f ((1 + U cos θ / c) t + x_n cos θ / c): the Doppler factor belongs to the time term only
(b = 1). With b = a the cone estimate is biased by δ(cos θ) ≈ −U cos² θ / c (1.7e-3 at 5 kn),
which matters only near end-fire (measured in ``docs/validation/narrowband.md``).

Real input (thesis eq. (3.21)): ``h_n = sin Φ_n``. Complex baseband input (the
``dft_filter`` stage's ``complex = true`` output, mixed down by ``fc``): ``h_n = exp(j Ψ_n)``
with ``Ψ_n = Φ_n − ψ``, ``ψ = 2π fc t`` the mixing phase at the sample's absolute time t, used
as the 2 N_H real measurements (Re, Im). The tonal's phase is not in the state: a phase offset
at the filter's start is absorbed by the frequency estimate (f̂ − f ≈ φ0 / (2π τ)), which is
the start-up "ripple" of thesis fig. 3.6, unless the start time origin is chosen so that the
model's phase matches (``align_phase`` in :mod:`.ekf`).

Jacobian (thesis eq. (3.23) for the frequency column when b = a)::

    ∂Φ_n/∂f = 2π u_n
    ∂Φ_n/∂θ = −2π f sin θ (U τ + b x_n + β U x_n cos θ / c) / c,   β = 1 if b = a else 0

Both grow with τ through ``s_n``: the reason the thesis re-initialises regularly.
"""

from __future__ import annotations

import numpy as np


def phase(theta: float, f: float, tau: float, x: np.ndarray, speed: float, c: float,
          spatial_doppler: bool = True) -> np.ndarray:
    """Element phases Φ_n (rad) of the model.

    Parameters
    ----------
    theta : float
        Cone angle, rad (0 forward end-fire).
    f : float
        Tonal frequency without own-speed Doppler, Hz.
    tau : float
        Time since the filter's (re)initialisation, s.
    x : (N,) ndarray
        Element positions along the body x axis, m (forward positive).
    speed : float
        Own speed along the array axis, m/s.
    c : float
        Sound speed, m/s.
    spatial_doppler : bool
        Doppler factor on the element delay term too (thesis eq. (3.18)); False: on the time
        term only.

    Returns
    -------
    (N,) ndarray
        Phases, rad.
    """
    a = 1.0 + speed * np.cos(theta) / c
    b = a if spatial_doppler else 1.0
    return 2.0 * np.pi * f * (a * tau + b * x * np.cos(theta) / c)


def phase_gradient(theta: float, f: float, tau: float, x: np.ndarray, speed: float,
                   c: float, spatial_doppler: bool = True) -> np.ndarray:
    """∂Φ_n/∂(θ, f): (N, 2) array, rad/rad and rad/Hz (thesis eq. (3.23))."""
    ct, st = np.cos(theta), np.sin(theta)
    a = 1.0 + speed * ct / c
    beta = 1.0 if spatial_doppler else 0.0
    b = 1.0 + beta * speed * ct / c
    u = a * tau + b * x * ct / c
    return np.stack([-2.0 * np.pi * f * st * (speed * tau + b * x + beta * speed * x * ct / c)
                     / c, 2.0 * np.pi * u], axis=1)


def measurement(theta: float, f: float, tau: float, x: np.ndarray, speed: float, c: float,
                mix: float | None = None, spatial_doppler: bool = True) -> np.ndarray:
    """Predicted measurement: ``sin Φ`` (N,) for real input (thesis eq. (3.21)), or
    ``exp(j(Φ − ψ))`` (N,) complex for baseband input when the mixing phase ``mix`` = ψ (rad)
    is given."""
    ph = phase(theta, f, tau, x, speed, c, spatial_doppler)
    if mix is None:
        return np.sin(ph)
    return np.exp(1j * (ph - mix))


def jacobian(theta: float, f: float, tau: float, x: np.ndarray, speed: float, c: float,
             mix: float | None = None, spatial_doppler: bool = True) -> np.ndarray:
    """Jacobian of :func:`measurement` w.r.t. (θ rad, f Hz): (N, 2) real for real input,
    (N, 2) complex (∂Re + j ∂Im) for baseband input (mixing phase ``mix``, rad)."""
    ph = phase(theta, f, tau, x, speed, c, spatial_doppler)
    g = phase_gradient(theta, f, tau, x, speed, c, spatial_doppler)
    if mix is None:
        return np.cos(ph)[:, None] * g
    return 1j * np.exp(1j * (ph - mix))[:, None] * g


def reflect_cone(theta: float) -> float:
    """Fold a cone angle (rad) back into [0, π] (cos θ is even, so the model is unchanged)."""
    t = np.mod(theta, 2.0 * np.pi)
    return float(2.0 * np.pi - t if t > np.pi else t)
