"""Plain numpy EKF of thesis eqs. (3.21)-(3.23), in the usual gain form, as the reference for the
numba kernel (which uses the information form): S = H P Hᵀ + R (M × M), K = P Hᵀ S⁻¹,
x⁺ = x⁻ + K (y − h), P⁺ = (I − K H) P⁻. Real input: M = N_H; complex: M = 2 N_H (Re, Im)."""

from __future__ import annotations

import numpy as np

from arrayproc.stages.narrowband.model import jacobian, measurement, reflect_cone


def ekf_reference(y: np.ndarray, tau0: float, dt: float, speed: float, x: np.ndarray, c: float,
                  mix0: float | None, mix_step: float, r: np.ndarray, q: np.ndarray,
                  state: np.ndarray, cov: np.ndarray, spatial_doppler: bool = True) -> np.ndarray:
    """Run the gain-form EKF over y (T, N) (complex when ``mix0``, the first sample's mixing
    phase in rad, is given; ``mix_step`` rad per sample); returns (T, 4) rows
    (θ, f, P_θθ, P_ff)."""
    st = np.array(state, float)
    p = np.array(cov, float)
    out = np.empty((y.shape[0], 4))
    cplx = mix0 is not None
    rr = np.concatenate([r, r]) if cplx else np.asarray(r, float)
    for k in range(y.shape[0]):
        tau = tau0 + k * dt
        p = p + np.diag(q) * dt
        mix = mix0 + k * mix_step if cplx else None
        h = measurement(st[0], st[1], tau, x, speed, c, mix, spatial_doppler)
        hj = jacobian(st[0], st[1], tau, x, speed, c, mix, spatial_doppler)
        if cplx:
            h = np.concatenate([h.real, h.imag])
            hj = np.concatenate([hj.real, hj.imag])
            yk = np.concatenate([y[k].real, y[k].imag])
        else:
            yk = y[k]
        s = hj @ p @ hj.T + np.diag(rr)
        gain = p @ hj.T @ np.linalg.inv(s)
        st = st + gain @ (yk - h)
        p = (np.eye(2) - gain @ hj) @ p
        p = 0.5 * (p + p.T)
        th = reflect_cone(st[0])
        if th != st[0] % (2 * np.pi):  # folded: the covariance's cross term changes sign
            p[0, 1] = p[1, 0] = -p[0, 1]
        st[0] = th
        out[k] = st[0], st[1], p[0, 0], p[1, 1]
    return out
