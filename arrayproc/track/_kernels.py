"""Numba kernel of the track initialisation from one bearing (Ristic, Arulampalam & Gordon
2003, ch. 6) with the priors of the L-R paper, section V; used by :mod:`arrayproc.track.init`
and the fused L-R Monte Carlo kernel."""

from __future__ import annotations

import math

from numba import njit


@njit(cache=True)
def init_from_bearing(z: float, own, r_mean: float, sigma_r: float, s_mean: float,
                      sigma_s: float, sigma_theta: float, sigma_c: float, sigma_psi: float,
                      x, P, r0: float, s0: float, dc: float) -> None:
    """Initialisation from the first bearing (Ristic, Arulampalam & Gordon 2003, ch. 6):
    range r ~ N(r̄, σr²) on the measured bearing, target speed s ~ N(s̄, σs²) on a course
    c ~ N(z + π, σc²) (heading towards the observer); Gaussian moments by linearisation.
    The mean is taken at (r0, s0, z + π + dc) — (r̄, s̄, z + π) for the prior mean, or a draw
    from the prior in Monte Carlo runs. For CT (len(x) == 5) the turn rate starts at 0 with
    standard deviation σψ."""
    n = x.shape[0]
    sz = math.sin(z)
    cz = math.cos(z)
    c = z + math.pi
    sc = math.sin(c)
    cc = math.cos(c)
    x[0] = r0 * sz
    x[1] = r0 * cz
    x[2] = s0 * math.sin(c + dc) - own[2]
    x[3] = s0 * math.cos(c + dc) - own[3]
    for i in range(n):
        for j in range(n):
            P[i, j] = 0.0
    rt2 = (r_mean * sigma_theta) ** 2
    sr2 = sigma_r * sigma_r
    P[0, 0] = rt2 * cz * cz + sr2 * sz * sz
    P[1, 1] = rt2 * sz * sz + sr2 * cz * cz
    P[0, 1] = P[1, 0] = (sr2 - rt2) * sz * cz
    sc2 = (s_mean * sigma_c) ** 2
    ss2 = sigma_s * sigma_s
    P[2, 2] = sc2 * cc * cc + ss2 * sc * sc
    P[3, 3] = sc2 * sc * sc + ss2 * cc * cc
    P[2, 3] = P[3, 2] = (ss2 - sc2) * sc * cc
    if n == 5:
        x[4] = 0.0
        P[4, 4] = sigma_psi * sigma_psi
