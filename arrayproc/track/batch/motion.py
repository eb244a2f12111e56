"""The array's own motion during a wavefront's passage: the correction of the measurements a
moving array makes (bearings of a line array, delays of any array) to those the batch TMA
models assume (elements frozen at the measurement time, thesis eqs. (3.44), (3.51)).

A plane wave from the unit direction ``u`` (pointing from the array to the source) crosses an
array that moves with velocity ``V`` through the water. Its wavefront moves along ``−u`` at
the speed of sound ``c``, so it reaches the element at body offset ``d`` from the reference at
``−(d·u)/c`` while the element has moved on by ``V t``: ``t = −(d + V t)·u / c``, i.e.

    t = −(d·u) / (c + V·u).                                                        (M1)

Every delay is the static delay ``−(d·u)/c`` scaled by ``1/(1 + V·u/c)``, and the static delay
the models expect is

    τ_static = τ_measured · (1 + V·u / c).                                         (M2)

For a 2-D array a common scale leaves the plane-wave direction unchanged (only the apparent
sound speed changes), but a line array measures the cone angle θ (0 at forward end-fire)
through ``cos θ = −c τ / d`` alone, so a line array moving along its axis at speed ``v``
(``V·u = v cos θ``) sees

    cos θ_apparent = cos θ / (1 + (v/c) cos θ),                                    (M3)
    cos θ = cos θ_apparent / (1 − (v/c) cos θ_apparent),                           (M4)

i.e. the cone angle pushed towards broadside by about ``(v/c) cos θ cot θ`` rad: 0.034° at
60° for 3 m/s in 1500 m/s. Both corrections are exact for a plane wave and a constant
velocity; (M2) neglects the wavefront's curvature in the ``V·u`` factor (relative error
``(aperture/range)·(v/c)``). ``V`` is the array's velocity through the water; the navigation
track gives it over ground, so a current is not accounted for.

The source moves too: what reaches the array at the measurement time ``t_b`` left the source
at the emission time ``t_b − R_b/c``, with ``R_b`` the distance from the emission point to the
receiver (the simulator and the sea both work this way, thesis eq. (2.47)). With the source at
constant velocity from the state ``x = [p0, v]`` at the window start (eq. (3.41)), the
emission point is

    p_e,b = p0 + v (τ_b − R_b/c),    R_b = √(|p_e,b − o_b|² + Δz_b²),               (M5)

solved by fixed-point iteration from ``R = |p0 + v τ_b − o_b|`` (a contraction by ``|v|/c``:
:data:`N_RETARD` updates of ``p_e`` leave a position error below ``R (|v|/c)^(N+1)``, under
2 cm for 10 m/s at 15 km, i.e. a bearing change below 2e-6 rad).
Ignoring it puts the model's source ``v R/c`` (6 m at 4 m/s and 2.3 km) ahead of the source
the measurements saw and, because ``R`` changes along the track, bends the track the
measurements describe away from a straight line by enough to move a batch solution by
several CRLB σ (measured on the simulated towed recording, docs/validation/batch_tma.md).
The derivative of (M5) is ``∂p_e/∂x = M⁻¹ [I, (τ_b − R_b/c) I]`` with
``M⁻¹ = I − v ûᵀ / (c + û·v)`` (Sherman-Morrison), ``û = (p_e − o)/R`` (horizontal part).
"""

from __future__ import annotations

import numpy as np

from ...geo.nav import Nav

__all__ = ["N_RETARD", "nav_velocity", "axial_speed", "static_cone", "static_delays",
           "emission_points", "emission_derivative"]

#: Fixed-point steps of the emission-time equation (M5) (fixed, so that the numba kernels and
#: the numpy models agree to rounding).
N_RETARD = 2


def nav_velocity(nav: Nav, times: np.ndarray) -> np.ndarray:
    """Velocity of the array reference point from the navigation track (m/s, east/north).

    The velocity of the nav segment containing each time (the track interpolates positions
    linearly between fixes, so this is its exact derivative); zero for a static array.

    Parameters
    ----------
    nav : Nav
        Navigation track (``/nav``).
    times : (B,) array_like
        s.

    Returns
    -------
    (B, 2) ndarray
    """
    t = np.atleast_1d(np.asarray(times, float))
    if nav.time.size < 2:
        return np.zeros((t.size, 2))
    v = np.diff(nav.position, axis=0) / np.diff(nav.time)[:, None]
    seg = np.clip(np.searchsorted(nav.time, t, side="right") - 1, 0, len(v) - 1)
    return v[seg]


def axial_speed(velocity: np.ndarray, heading_rad: np.ndarray) -> np.ndarray:
    """Velocity component along the array's axis (its heading), m/s.

    Parameters
    ----------
    velocity : (B, 2) array_like
        m/s, east/north.
    heading_rad : (B,) array_like
        Array heading (forward end-fire), rad clockwise from north.

    Returns
    -------
    (B,) ndarray
    """
    v = np.asarray(velocity, float).reshape(-1, 2)
    h = np.asarray(heading_rad, float).reshape(-1)
    return v[:, 0] * np.sin(h) + v[:, 1] * np.cos(h)


def static_cone(cone_rad: np.ndarray, axial_speed_mps: np.ndarray,
                sound_speed: float) -> np.ndarray:
    """Cone angle a static line array would measure, from a moving one's (eq. (M4)).

    Parameters
    ----------
    cone_rad : (B,) array_like
        Measured (apparent) cone angles, rad from forward end-fire.
    axial_speed_mps : float or (B,) array_like
        The array's speed along its axis (forward positive), m/s.
    sound_speed : float
        m/s.

    Returns
    -------
    (B,) ndarray
        ``arccos(cos θ_app / (1 − (v/c) cos θ_app))``, rad (clipped to [0, π]).
    """
    ca = np.cos(np.asarray(cone_rad, float))
    b = np.asarray(axial_speed_mps, float) / float(sound_speed)
    return np.arccos(np.clip(ca / (1.0 - b * ca), -1.0, 1.0))


def static_delays(delays_s: np.ndarray, v_dot_u: np.ndarray, sound_speed: float) -> np.ndarray:
    """Delays a static array would measure, from a moving one's (eq. (M2)).

    Parameters
    ----------
    delays_s : (B, N) array_like
        Measured delays to the reference element (s).
    v_dot_u : (B,) array_like
        ``V·u`` at each snapshot: the array velocity's component towards the source (m/s).
    sound_speed : float
        m/s.

    Returns
    -------
    (B, N) ndarray
        ``τ (1 + V·u/c)`` (s).
    """
    return np.asarray(delays_s, float) * (
        1.0 + np.asarray(v_dot_u, float).reshape(-1, 1) / float(sound_speed))


def emission_points(state: np.ndarray, tau: np.ndarray, obs: np.ndarray, sound_speed: float,
                    dz2: np.ndarray | float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Source positions at the emission times of what the receivers get at ``τ_b`` (eq. (M5)).

    Parameters
    ----------
    state : (..., 4) array_like
        [x, y, vx, vy] at the window start (m, m/s).
    tau : (B,) array_like
        Reception times since the window start (s).
    obs : (B, 2) array_like
        Receiver (observer or reference element) positions (m).
    sound_speed : float
        m/s.
    dz2 : float or (B,) array_like
        Squared depth difference receiver − source (m²); 0 for the planar model.

    Returns
    -------
    p_e : (..., B, 2) ndarray
        Emission points (m).
    tau_e : (..., B) ndarray
        Emission times since the window start, ``τ_b − R_b/c`` (s).
    """
    x = np.asarray(state, float)
    t = np.asarray(tau, float)
    o = np.asarray(obs, float)
    p0, v = x[..., None, :2], x[..., None, 2:]
    d = p0 + t[:, None] * v - o
    r = np.sqrt(np.sum(d * d, -1) + dz2)
    for k in range(N_RETARD):
        tau_e = t - r / sound_speed
        if k < N_RETARD - 1:
            d = p0 + tau_e[..., None] * v - o
            r = np.sqrt(np.sum(d * d, -1) + dz2)
    return p0 + tau_e[..., None] * v, tau_e


def emission_derivative(state: np.ndarray, p_e: np.ndarray, obs: np.ndarray,
                        sound_speed: float, dz2: np.ndarray | float = 0.0) -> np.ndarray:
    """``M⁻¹ = I − v ûᵀ / (c + û·v)`` of eq. (M5)'s derivative, per measurement.

    Parameters
    ----------
    state : (..., 4) array_like
        [x, y, vx, vy] (m, m/s).
    p_e : (..., B, 2) array_like
        Emission points (:func:`emission_points`).
    obs : (B, 2) array_like
        Receivers (m).
    sound_speed : float
        m/s.
    dz2 : float or (B,) array_like
        Squared depth differences (m²).

    Returns
    -------
    (..., B, 2, 2) ndarray
        ``∂p_e/∂x = M⁻¹ [I, τ_e I]``; a model gradient ``g`` w.r.t. ``p_e`` becomes
        ``g M⁻¹`` w.r.t. ``p0`` and ``τ_e g M⁻¹`` w.r.t. ``v``.
    """
    x = np.asarray(state, float)
    d = np.asarray(p_e, float) - np.asarray(obs, float)
    r = np.sqrt(np.sum(d * d, -1) + dz2)
    u = d / r[..., None]
    v = np.broadcast_to(x[..., None, 2:], u.shape)
    den = sound_speed + np.sum(u * v, -1)
    eye = np.eye(2)
    return eye - v[..., :, None] * u[..., None, :] / den[..., None, None]
