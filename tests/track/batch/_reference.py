"""Plain numpy implementations of the batch-TMA objectives (the references of the numba
kernels; the TMA benchmark script times its own equivalents)."""

from __future__ import annotations

import numpy as np


def wrap(a: np.ndarray) -> np.ndarray:
    return (a + np.pi) % (2 * np.pi) - np.pi


def emission(pop: np.ndarray, tau: np.ndarray, ox: np.ndarray, oy: np.ndarray, c: float,
             dz2: np.ndarray | float = 0.0, n_iter: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """Source (x, y) (P, B) at the emission time t_e = τ − R/c, R the distance from the
    emission point to the receiver (ox, oy), by n_iter position updates from R(τ)."""
    px = pop[0][:, None] + pop[2][:, None] * tau[None, :]
    py = pop[1][:, None] + pop[3][:, None] * tau[None, :]
    ex, ey = px, py
    for _ in range(n_iter):
        dt = np.sqrt((ex - ox) ** 2 + (ey - oy) ** 2 + dz2) / c
        ex = px - pop[2][:, None] * dt
        ey = py - pop[3][:, None] * dt
    return ex, ey


def bo_cost(pop: np.ndarray, tau: np.ndarray, obs: np.ndarray, meas: np.ndarray,
            weight: np.ndarray, c: float | None = None) -> np.ndarray:
    """Σ_b (w_b wrap(θ_b − atan2(dx, dy)))² for pop (4, P); source at the emission time
    when c is given."""
    if c:
        ex, ey = emission(pop, tau, obs[None, :, 0], obs[None, :, 1], c)
    else:
        ex = pop[0][:, None] + pop[2][:, None] * tau[None, :]
        ey = pop[1][:, None] + pop[3][:, None] * tau[None, :]
    r = wrap(meas[None, :] - np.arctan2(ex - obs[None, :, 0], ey - obs[None, :, 1]))
    return ((r * weight[None, :]) ** 2).sum(1)


def td_cost(pop: np.ndarray, tau: np.ndarray, elem: np.ndarray, meas: np.ndarray,
            weight: np.ndarray, ref: int, c: float, dz2: np.ndarray | None = None,
            retarded: bool = False) -> np.ndarray:
    """Σ_bn (w_bn (τ_bn − (r_bn − r_b,ref)/c))² for pop (4, P), r_bn = √(d² + Δz²)."""
    dz2 = np.zeros(elem.shape[:2]) if dz2 is None else dz2
    if retarded:
        px, py = emission(pop, tau, elem[None, :, ref, 0], elem[None, :, ref, 1], c,
                          dz2[None, :, ref])
    else:
        px = pop[0][:, None] + pop[2][:, None] * tau[None, :]          # (P, B)
        py = pop[1][:, None] + pop[3][:, None] * tau[None, :]
    r = np.sqrt((px[..., None] - elem[None, :, :, 0]) ** 2
                + (py[..., None] - elem[None, :, :, 1]) ** 2 + dz2[None])   # (P, B, N)
    h = (r - r[..., ref:ref + 1]) / c
    return (((meas[None] - h) * weight[None]) ** 2).sum((1, 2))


def compact_cost_dense(xs, ys, headings, speed, tau, array_xy, meas, cov):
    """eᵀC⁻¹e on the grid with the dense C (Cholesky whitening), (I, J, K)."""
    lw = np.linalg.inv(np.linalg.cholesky(cov))
    out = np.empty((xs.size, ys.size, headings.size))
    for k, g in enumerate(headings):
        px = xs[:, None, None] + speed * np.sin(g) * tau[None, None, :] - array_xy[0]
        py = ys[None, :, None] + speed * np.cos(g) * tau[None, None, :] - array_xy[1]
        e = wrap(meas[None, None, :] - np.arctan2(px, py))
        z = e @ lw.T
        out[:, :, k] = (z**2).sum(-1)
    return out


def exp_cov(times: np.ndarray, sigma: float, corr: float) -> np.ndarray:
    dt = np.abs(times[:, None] - times[None, :])
    return sigma**2 * (np.exp(-dt / corr) if corr > 0 else (dt == 0).astype(float))
