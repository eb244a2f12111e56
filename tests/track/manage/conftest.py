"""Shared simulation for the manager tests: targets in 2-D with position measurements."""

from __future__ import annotations

import numpy as np


def simulate_cv(n_targets: int, n_scans: int, seed: int, dt: float = 1.0, sigma: float = 5.0,
                pd: float = 1.0, clutter: int = 0, area: float = 2000.0,
                spacing: float = 300.0) -> tuple[np.ndarray, list[np.ndarray], list[np.ndarray]]:
    """Straight-line targets (truth (n_targets, n_scans, 4)) and per-scan position
    measurements with labels (−1: clutter)."""
    rng = np.random.default_rng(seed)
    x0 = np.stack([np.arange(n_targets) * spacing - area / 2,
                   rng.uniform(-area / 4, area / 4, n_targets),
                   rng.uniform(-5, 5, n_targets), rng.uniform(-5, 5, n_targets)], 1)
    t = np.arange(n_scans) * dt
    truth = np.empty((n_targets, n_scans, 4))
    truth[..., :2] = x0[:, None, :2] + t[None, :, None] * x0[:, None, 2:]
    truth[..., 2:] = x0[:, None, 2:]
    Zs, labels = [], []
    for k in range(n_scans):
        det = rng.random(n_targets) < pd
        z = truth[det, k, :2] + sigma * rng.standard_normal((det.sum(), 2))
        c = rng.uniform(-area, area, (rng.poisson(clutter) if clutter else 0, 2))
        Zs.append(np.vstack([z, c]))
        labels.append(np.concatenate([np.flatnonzero(det), -np.ones(len(c), int)]))
    return truth, Zs, labels
