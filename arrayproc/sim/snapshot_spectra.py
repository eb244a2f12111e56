"""Snapshot-model spectra for the adaptive and subspace beamformers, in closed form.

Element spectra of independent (or coherent) complex Gaussian plane waves plus white noise,
x_k(f) = Σ_i s_ik(f) a(θ_i, f) + n_k(f), with a_n = exp(+j2πf x_n cos θ/c) the steering vector
of ``cbf`` (body x only, centroid reference), and the ``("snapshot", "freq", "channel")``
spectra blocks the stages read directly (Hann snapshots of ``NFFT`` samples every ``HOP`` at
``FS``). The time-domain far-field signals are :mod:`arrayproc.sim.plane_wave`.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from arrayproc.chain.block import Block
from arrayproc.chain.domains import Domain, SnapshotMeta

__all__ = ["C", "NFFT", "HOP", "FS", "steer", "spectra", "blocks"]

C = 1500.0  # sound speed, m/s
NFFT, HOP, FS = 1024, 512, 5120.0  # snapshot grid of the blocks: samples, samples, Hz


def steer(pos: np.ndarray, cone_deg: float, f: np.ndarray) -> np.ndarray:
    """(F, C) steering vectors of a cone angle (body x only, centroid reference)."""
    x = pos[:, 0] - pos[:, 0].mean()
    return np.exp(2j * np.pi * f[:, None] * x[None, :] * np.cos(np.deg2rad(cone_deg)) / C)


def spectra(pos: np.ndarray, freqs: np.ndarray, cones: list[float], snr_db: float,
            n_snap: int, rng: np.random.Generator, coherent: bool = False,
            noise: float = 1.0) -> np.ndarray:
    """(S, F, C) complex element spectra: unit-variance complex noise per element, each source
    at ``snr_db`` per element; ``coherent`` gives every source the same waveform."""
    c = pos.shape[0]
    shape = (n_snap, freqs.size)
    x = noise * (rng.standard_normal(shape + (c,)) + 1j * rng.standard_normal(shape + (c,)))
    x /= np.sqrt(2.0)
    amp = noise * 10 ** (snr_db / 20)
    def gauss():
        return (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) / np.sqrt(2)

    common = gauss()
    for cone in cones:
        s = common if coherent else gauss()
        x += amp * s[..., None] * steer(pos, cone, freqs)[None]
    return x


def blocks(x: np.ndarray, freqs: np.ndarray, pos: np.ndarray, per_block: int = 64,
           first: int = 0) -> Iterator[Block]:
    """Spectra blocks of ``x`` (S, F, C) on the snapshot grid from snapshot ``first``."""
    for i in range(0, x.shape[0], per_block):
        part = x[i:i + per_block]
        k = first + i + np.arange(part.shape[0])
        starts = k * HOP
        times = (starts + 0.5 * NFFT) / FS
        meta = SnapshotMeta(times, np.zeros(k.size), NFFT, HOP, "hann", FS / NFFT,
                            starts=starts)
        yield Block(part.astype(np.complex64), Domain.SPECTRA, starts[0] / FS,
                    (starts[-1] - starts[0] + NFFT) / FS, FS, pos, None, freqs, None, int(k[0]),
                    meta)
