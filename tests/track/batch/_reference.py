"""Plain numpy implementations of the batch-TMA objectives (the references of the numba
kernels; also used by scripts/bench_tma.py's equivalents)."""

from __future__ import annotations

import numpy as np


def wrap(a: np.ndarray) -> np.ndarray:
    return (a + np.pi) % (2 * np.pi) - np.pi


def bo_cost(pop: np.ndarray, tau: np.ndarray, obs: np.ndarray, meas: np.ndarray,
            weight: np.ndarray) -> np.ndarray:
    """Σ_b (w_b wrap(θ_b − atan2(dx, dy)))² for pop (4, P)."""
    px = pop[0][:, None] + pop[2][:, None] * tau[None, :] - obs[None, :, 0]
    py = pop[1][:, None] + pop[3][:, None] * tau[None, :] - obs[None, :, 1]
    r = wrap(meas[None, :] - np.arctan2(px, py)) * weight[None, :]
    return (r**2).sum(1)


def td_cost(pop: np.ndarray, tau: np.ndarray, elem: np.ndarray, meas: np.ndarray,
            weight: np.ndarray, ref: int, c: float) -> np.ndarray:
    """Σ_bn (w_bn (τ_bn − (r_bn − r_b,ref)/c))² for pop (4, P)."""
    px = pop[0][:, None] + pop[2][:, None] * tau[None, :]              # (P, B)
    py = pop[1][:, None] + pop[3][:, None] * tau[None, :]
    r = np.sqrt((px[..., None] - elem[None, :, :, 0]) ** 2
                + (py[..., None] - elem[None, :, :, 1]) ** 2)            # (P, B, N)
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
