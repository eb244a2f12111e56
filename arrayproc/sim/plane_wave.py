"""Far-field plane waves on an array, built in closed form (no propagation model).

The test-signal generators that the beamformer checks compare against: a tonal from one cone
angle, independent broadband sources applied with exact frequency-domain delays, and tonals
seen by an array towed along its axis with a lateral offset (thesis 2.2.2). The cone angle θ0
is measured from the array's +x axis (0° forward end-fire, 90° broadside); an element at axial
position x_n receives the wavefront x_n cos θ0 / c earlier than the origin (thesis eq. (2.10)
without motion). The full simulator (:mod:`arrayproc.sim.run`) adds spreading, retarded times
and platform motion; these are its far-field limit.
"""

from __future__ import annotations

import numpy as np

__all__ = ["plane_wave_advances", "tonal_plane_wave", "broadband_plane_waves",
           "towed_tonal_plane_waves"]


def plane_wave_advances(positions: np.ndarray, cone_deg: float, c: float = 1500.0
                        ) -> np.ndarray:
    """Time advance τ_n = x_n cos θ0 / c (s) of each element for a plane wave from ``cone_deg``.

    Parameters
    ----------
    positions : (N, 3) or (N, 2) array
        Element positions, m; column 0 is the array axis.
    cone_deg : float
        Cone angle θ0 of the arrival, deg.
    c : float
        Sound speed, m/s.

    Returns
    -------
    (N,) ndarray
        Advances, s (positive: the element hears the wavefront first).
    """
    return np.asarray(positions)[:, 0] * np.cos(np.deg2rad(cone_deg)) / c


def tonal_plane_wave(n: int, fs: float, positions: np.ndarray, cone_deg: float, freq: float,
                     amp: float = 1.0, phase: float = 0.3, c: float = 1500.0) -> np.ndarray:
    """Exact tonal plane wave x_n(t) = A cos(2π f (t + x_n cos θ0 / c) + φ) (thesis eq. (2.10)).

    Parameters
    ----------
    n : int
        Samples.
    fs : float
        Sample rate, Hz.
    positions : (N, 3) array
        Element positions, m.
    cone_deg : float
        Cone angle of the source, deg.
    freq : float
        Frequency, Hz.
    amp : float
        Amplitude A.
    phase : float
        Phase φ at t = 0 at the origin, rad.
    c : float
        Sound speed, m/s.

    Returns
    -------
    (n, N) ndarray
    """
    t = np.arange(n) / fs
    tau = plane_wave_advances(positions, cone_deg, c)
    return amp * np.cos(2 * np.pi * freq * (t[:, None] + tau[None, :]) + phase)


def broadband_plane_waves(n: int, fs: float, positions: np.ndarray, cones_deg, amps,
                          rng: np.random.Generator, c: float = 1500.0) -> np.ndarray:
    """Independent white-noise sources arriving as plane waves from ``cones_deg``.

    Each source is ``amp · N(0, 1)`` white noise; element n receives it advanced by τ_n,
    applied exactly as the phase ramp e^{j2πfτ_n} on the record's FFT (so the delay is
    circular over the whole record).

    Parameters
    ----------
    n : int
        Samples.
    fs : float
        Sample rate, Hz.
    positions : (N, 3) array
        Element positions, m.
    cones_deg, amps : sequences of float
        Cone angle (deg) and standard deviation of each source.
    rng : numpy.random.Generator
        Source of the noise (one ``standard_normal(n)`` draw per source, in order).
    c : float
        Sound speed, m/s.

    Returns
    -------
    (n, N) ndarray
    """
    positions = np.asarray(positions)
    f = np.fft.rfftfreq(n, 1 / fs)
    x = np.zeros((n, positions.shape[0]))
    for cone, a in zip(cones_deg, amps, strict=True):
        s = np.fft.rfft(a * rng.standard_normal(n))
        tau = plane_wave_advances(positions, cone, c)
        x += np.fft.irfft(s[:, None] * np.exp(2j * np.pi * f[:, None] * tau[None, :]), n,
                          axis=0)
    return x


def towed_tonal_plane_waves(t: np.ndarray, positions: np.ndarray, speed: float, waves,
                            c: float = 1500.0, lateral: np.ndarray | None = None,
                            phases=None) -> np.ndarray:
    """Stationary tonal plane waves seen by a line array moving along its axis.

    p_n(t) = Σ_w A_w cos(2π f_w (t + (l(t) sin θ_w + (U t + x_n) cos θ_w) / c) + φ_w): element
    n at axial position U t + x_n and lateral offset l(t) (thesis 2.2.2), each wave from cone
    θ_w on the starboard side.

    Parameters
    ----------
    t : (T,) array
        Times, s.
    positions : (N, 3) array
        Element positions along the axis (column 0), m.
    speed : float
        Array speed U along its axis, m/s.
    waves : sequence of (freq Hz, cone deg, amplitude)
        The plane waves.
    c : float
        Sound speed, m/s.
    lateral : (T,) array, optional
        Lateral offset l(t), m (default 0).
    phases : sequence of float, optional
        φ_w, rad (default 0).

    Returns
    -------
    (T, N) ndarray
        The waves summed in order.
    """
    t = np.asarray(t, float)
    lat = np.zeros_like(t) if lateral is None else np.asarray(lateral, float)
    x = np.zeros((t.size, np.asarray(positions).shape[0]))
    along = speed * t[:, None] + np.asarray(positions)[None, :, 0]
    for i, (f, cone, amp) in enumerate(waves):
        u, s = np.cos(np.deg2rad(cone)), np.sin(np.deg2rad(cone))
        phase = 0.0 if phases is None else phases[i]
        x += amp * np.cos(2 * np.pi * f * (t[:, None] + (lat[:, None] * s + along * u) / c)
                          + phase)
    return x
