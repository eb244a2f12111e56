"""Time differences of arrival (TDOA) at array elements: prediction, Jacobian, Fisher information.

A source at ``s`` (world frame x east, y north, z down, m) is heard by element ``i`` at ``p_i``
after |s − p_i|/c; relative to a reference element (thesis eq. (3.25) in 3-D)

    τ_i(s) = (|s − p_i| − |s − p_ref|) / c,        ∂τ_i/∂s = (u_i − u_ref)/c,

u_i the unit vector from p_i to s. The delay of the reference is 0 and carries no information;
the Fisher information of the other delays, with error covariance C, is (thesis eq. (C.8))

    F(s) = Hᵀ C⁻¹ H,   H = ∂τ/∂s (rows of the non-reference elements),

and the Cramér-Rao bound on an unbiased position estimate is F⁻¹. Far from the array the delays
tend to the plane-wave delays τ_i = −(p_i − p_ref)·u/c of a source in direction u
(:func:`plane_wave_delays`), the model of the bearing-only fallback for planar and line arrays.

Delays measured against one reference channel share that channel's noise:
:func:`reference_covariance` builds the covariance C that follows. Pure numpy; used by the
``localise`` stage and by the tracker's TDOA measurement model.
"""

from __future__ import annotations

import numpy as np


def predicted_delays(source: np.ndarray, elements: np.ndarray, reference: int,
                     c: float) -> np.ndarray:
    """TDOA of every element relative to the reference.

    Parameters
    ----------
    source : (..., 3) array
        Source position(s), m.
    elements : (n, 3) array
        Element positions, m (same frame).
    reference : int
        Reference element.
    c : float
        Sound speed, m/s.

    Returns
    -------
    (..., n) ndarray
        Delays, s (0 at the reference).
    """
    s = np.asarray(source, float)[..., None, :]
    r = np.linalg.norm(s - np.asarray(elements, float), axis=-1)
    return (r - r[..., reference:reference + 1]) / c


def jacobian(source: np.ndarray, elements: np.ndarray, reference: int, c: float) -> np.ndarray:
    """∂τ_i/∂s of :func:`predicted_delays` at one source position.

    Parameters
    ----------
    source : (3,) array
        Source position, m.
    elements : (n, 3) array
        Element positions, m.
    reference : int
        Reference element.
    c : float
        Sound speed, m/s.

    Returns
    -------
    (n, 3) ndarray
        s/m; the reference row is zero.
    """
    d = np.asarray(source, float)[None, :] - np.asarray(elements, float)
    u = d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-12)
    return (u - u[reference]) / c


def plane_wave_delays(direction: np.ndarray, elements: np.ndarray, reference: int,
                      c: float) -> np.ndarray:
    """Far-field delays of a source in unit direction ``direction`` (from the array), s.

    Parameters
    ----------
    direction : (..., 3) array
        Unit vector(s) towards the source.
    elements : (n, 3) array
        Element positions, m.
    reference : int
        Reference element.
    c : float
        Sound speed, m/s.

    Returns
    -------
    (..., n) ndarray
        −(p_i − p_ref)·u / c.
    """
    p = np.asarray(elements, float)
    return -np.einsum("nk,...k->...n", p - p[reference], np.asarray(direction, float)) / c


def reference_covariance(sigma: np.ndarray) -> np.ndarray:
    """Covariance of delays all measured against one reference channel.

    With τ_i = e_i − e_ref (independent arrival-time errors), var τ_i = v_i + v_ref and
    cov(τ_i, τ_j) = v_ref. Only the σ_i are known; the reference's share is taken as half the
    smallest variance, v_ref = min σ²/2 (exact when the channels' SNRs are equal, and never
    larger than any pair allows).

    Parameters
    ----------
    sigma : (m,) array
        Standard deviations of the non-reference delays, s.

    Returns
    -------
    (m, m) ndarray
        s².
    """
    v = np.asarray(sigma, float) ** 2
    v_ref = 0.5 * float(v.min()) if v.size else 0.0
    return np.diag(v - v_ref) + v_ref


def fisher_information(source: np.ndarray, elements: np.ndarray, reference: int, c: float,
                       cov: np.ndarray) -> np.ndarray:
    """Fisher information of the TDOA of the non-reference elements about the position.

    Parameters
    ----------
    source : (3,) array
        Source position, m.
    elements : (n, 3) array
        Element positions, m.
    reference : int
        Reference element.
    c : float
        Sound speed, m/s.
    cov : (n−1,) or (n−1, n−1) array
        Standard deviations (s) of independent delays, or their covariance (s²), in element
        order without the reference.

    Returns
    -------
    (3, 3) ndarray
        F = Hᵀ C⁻¹ H, m⁻².
    """
    H = np.delete(jacobian(source, elements, reference, c), reference, axis=0)
    C = np.asarray(cov, float)
    if C.ndim == 1:
        C = np.diag(C**2)
    return H.T @ np.linalg.solve(C, H)


def crlb(source: np.ndarray, elements: np.ndarray, reference: int, c: float,
         cov: np.ndarray) -> np.ndarray:
    """Cramér-Rao bound on the position, the inverse of :func:`fisher_information`.

    Parameters and units as :func:`fisher_information`.

    Returns
    -------
    (3, 3) ndarray
        m².
    """
    return np.linalg.inv(fisher_information(source, elements, reference, c, cov))


def arrival_covariance(variance: np.ndarray, reference: int) -> np.ndarray:
    """Covariance of delays against one reference from each channel's arrival-time variance.

    τ_i = e_i − e_ref with independent errors of variance v_i: var τ_i = v_i + v_ref,
    cov(τ_i, τ_j) = v_ref (the known-shares form of :func:`reference_covariance`).

    Parameters
    ----------
    variance : (n,) array
        v_i of every channel, s² (e.g. :func:`arrayproc.stages.delay.bounds.arrival_variance`).
    reference : int
        Reference channel.

    Returns
    -------
    (n−1, n−1) ndarray
        s², channels in order without the reference.
    """
    v = np.asarray(variance, float)
    rest = np.delete(v, reference)
    return np.diag(rest) + v[reference]
