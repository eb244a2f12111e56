"""Closed-form test data for a towed line array: far-field tonal plane waves seen by an array
moving along its axis, with optional per-snapshot lateral offsets, plus white noise."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from arrayproc.io.geometry import line_array
from arrayproc.sim.plane_wave import towed_tonal_plane_waves
from tests.conftest import write_recording


def towed_tonals(path: Path, fs: float, duration: float, speed: float,
                 waves: list[tuple[float, float, float]], noise_std: float = 0.0,
                 n: int = 64, dx: float = 0.36, c: float = 1500.0,
                 lateral_std: float = 0.0, lateral_snapshot: float = 1.0,
                 seed: int = 0) -> Path:
    """Write a recording: array heading north at ``speed`` m/s; each wave (freq Hz, cone deg,
    amplitude Pa) is a stationary plane wave from the starboard side,
    p(r, t) = A cos(2π f (t + r·k / c) + φ), k the unit vector towards the source.
    The array is displaced sideways by a Gaussian offset, constant over each
    ``lateral_snapshot`` s (thesis 2.2.2)."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(round(duration * fs))) / fs
    pos = line_array(n, dx)
    lat = np.zeros_like(t)
    if lateral_std > 0:
        k = (t // lateral_snapshot).astype(int)
        lat = rng.normal(0.0, lateral_std, k.max() + 1)[k]
    phases = [rng.uniform(0, 2 * np.pi) for _ in waves]
    x = towed_tonal_plane_waves(t, pos, speed, waves, c, lat, phases)
    if noise_std > 0:
        x += noise_std * rng.standard_normal(x.shape)
    tn = np.arange(0.0, duration + 1.0, 1.0)
    nav = dict(time=tn, position=np.stack([np.zeros_like(tn), speed * tn], -1),
               heading=np.zeros_like(tn))
    return write_recording(path, x.astype(np.float32), fs=fs, positions=pos, nav=nav)
