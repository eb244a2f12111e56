"""Numba kernel of ``cbf_azel``: the band power of every direction of an azimuth × elevation
grid from the pair cross-correlations sampled on a fine lag grid (see :mod:`cbf_azel`).

Hand-written because no library evaluates a steered response from tabulated pair
correlations with a per-snapshot rotation of the grid (the array heading).
"""

from __future__ import annotations

import numba as nb
import numpy as np


@nb.njit(cache=True, fastmath=False, parallel=False)
def azel_power(rho: np.ndarray, lag0: float, dlag: float, base: np.ndarray,
               auto: np.ndarray, grid: np.ndarray, headings_rad: np.ndarray,
               out: np.ndarray) -> None:
    """P_s(d) = Σ_n w_n² E_n + 2 Σ_p w_m w_n Re ρ_p(Δ_p(d)) (cbf_azel eq. 2).

    ``rho`` (S, P, M) float32: Re ρ_p on the lags ``lag0 + k·dlag`` (s), already scaled by
    w_m w_n; ``base`` (P, 3): the pair baselines (r_m − r_n)/c (s/1) in the body frame;
    ``auto`` (S,): Σ_n w_n² E_n; ``grid`` (D, 3): world components of each direction
    (cos el cos az, cos el sin az, −sin el); ``headings_rad`` (S,); ``out`` (S, D) float32.
    Four-point Lagrange interpolation between lag samples (cbf_azel eq. 3).
    """
    n_s, n_p, n_m = rho.shape
    n_d = grid.shape[0]
    inv = 1.0 / dlag
    for s in range(n_s):
        ch = np.cos(headings_rad[s])
        sh = np.sin(headings_rad[s])
        a0 = auto[s]
        for d in range(n_d):
            gx, gy, gz = grid[d, 0], grid[d, 1], grid[d, 2]
            ux = gx * ch + gy * sh  # body x (forward)
            uy = gy * ch - gx * sh  # body y (starboard)
            acc = 0.0
            for p in range(n_p):
                t = ((base[p, 0] * ux + base[p, 1] * uy + base[p, 2] * gz) - lag0) * inv
                i = int(np.floor(t))
                if i < 1:
                    i = 1
                elif i > n_m - 3:
                    i = n_m - 3
                u = t - i
                # Lagrange weights on the nodes i-1, i, i+1, i+2 at offset u
                um1 = u + 1.0
                u1 = u - 1.0
                u2 = u - 2.0
                w0 = -u * u1 * u2 / 6.0
                w1 = um1 * u1 * u2 / 2.0
                w2 = -um1 * u * u2 / 2.0
                w3 = um1 * u * u1 / 6.0
                r = rho[s, p]
                acc += w0 * r[i - 1] + w1 * r[i] + w2 * r[i + 1] + w3 * r[i + 2]
            out[s, d] = a0 + 2.0 * acc
