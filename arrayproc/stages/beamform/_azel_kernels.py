"""Numba kernel of ``cbf_azel``: the band power of every direction of an azimuth × elevation
grid from the pair cross-correlations sampled on a fine lag grid (see :mod:`cbf_azel`).

Hand-written because no library evaluates a steered response from tabulated pair
correlations with a rotation of the grid by the array heading. The snapshots of one heading
are the innermost (contiguous) axis, so each direction's lag and interpolation weights are
computed once for all of them and the four-tap sums vectorise across snapshots.
"""

from __future__ import annotations

import numba as nb
import numpy as np


@nb.njit(cache=True, fastmath=True)
def azel_power(rho: np.ndarray, lag0: float, dlag: float, base: np.ndarray,
               auto: np.ndarray, grid: np.ndarray, heading_rad: float,
               out: np.ndarray) -> None:
    """P_s(d) = Σ_n E_n + 2 Σ_p Re ρ_p(Δ_p(d)) (cbf_azel eq. 2) for snapshots of one heading.

    ``rho`` (P, M, S) float32: Re ρ_p of each snapshot s on the lags ``lag0 + k·dlag`` (s);
    ``base`` (P, 3): the pair baselines (r_m − r_n)/c (s) in the body frame; ``auto`` (S,):
    Σ_n Σ_f |X_n|²; ``grid`` (D, 3): world components of each direction (cos e cos a,
    cos e sin a, −sin e); ``out`` (S, D) float32. Four-point Lagrange interpolation between
    lag samples (cbf_azel eq. 3).
    """
    n_p, n_m, n_s = rho.shape
    n_d = grid.shape[0]
    inv = 1.0 / dlag
    ch = np.cos(heading_rad)
    sh = np.sin(heading_rad)
    acc = np.empty(n_s, np.float32)
    for d in range(n_d):
        gx, gy, gz = grid[d, 0], grid[d, 1], grid[d, 2]
        ux = gx * ch + gy * sh  # body x (forward)
        uy = gy * ch - gx * sh  # body y (starboard)
        acc[:] = 0.0
        for p in range(n_p):
            t = ((base[p, 0] * ux + base[p, 1] * uy + base[p, 2] * gz) - lag0) * inv
            i = int(np.floor(t))
            if i < 1:
                i = 1
            elif i > n_m - 3:
                i = n_m - 3
            u = t - i
            # Lagrange weights of the nodes i-1, i, i+1, i+2 at offset u
            um1 = u + 1.0
            u1 = u - 1.0
            u2 = u - 2.0
            w0 = np.float32(-u * u1 * u2 / 6.0)
            w1 = np.float32(um1 * u1 * u2 / 2.0)
            w2 = np.float32(-um1 * u * u2 / 2.0)
            w3 = np.float32(um1 * u * u1 / 6.0)
            r0, r1, r2, r3 = rho[p, i - 1], rho[p, i], rho[p, i + 1], rho[p, i + 2]
            for s in range(n_s):
                acc[s] += w0 * r0[s] + w1 * r1[s] + w2 * r2[s] + w3 * r3[s]
        for s in range(n_s):
            out[s, d] = auto[s] + 2.0 * acc[s]
