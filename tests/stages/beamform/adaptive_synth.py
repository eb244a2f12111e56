"""Snapshot-model test data for the adaptive and subspace beamformers: element spectra of
independent (or coherent) complex Gaussian plane waves plus white noise,
x_k(f) = Σ_i s_ik(f) a(θ_i, f) + n_k(f), with a_n = exp(+j2πf x_n cos θ/c) the steering vector
of ``cbf``, as ``("snapshot", "freq", "channel")`` blocks the stages read directly."""

from __future__ import annotations

import numpy as np

from arrayproc.chain.block import Block
from arrayproc.chain.domains import Domain, SnapshotMeta

C = 1500.0
NFFT, HOP, FS = 1024, 512, 5120.0


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
           first: int = 0):
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


class Rows:
    """A stand-in products group that keeps appended rows (for stages that write products)."""

    def __init__(self) -> None:
        self.rows: dict[str, list] = {}
        self.attrs: dict = {}

    def append(self, **cols) -> None:
        for k, v in cols.items():
            self.rows.setdefault(k, []).append(np.asarray(v))

    def set(self, name, data, **attrs) -> None:
        self.rows[name] = [np.asarray(data)]

    def column(self, name: str) -> np.ndarray:
        return np.concatenate(self.rows.get(name, [np.zeros(0)]))


class Products:
    """A stand-in products writer handing out :class:`Rows` groups."""

    def __init__(self) -> None:
        self.groups: dict[str, Rows] = {}

    def group(self, name, kind, stage=None, **attrs) -> Rows:
        return self.groups.setdefault(name, Rows())


def local_peaks(p: np.ndarray, axis: np.ndarray, n: int = 2) -> list[float]:
    """The ``n`` strongest local maxima of ``p`` (B,), parabolically refined (dB), in deg."""
    y = 10 * np.log10(np.maximum(p, 1e-300))
    i = np.flatnonzero((y[1:-1] > y[:-2]) & (y[1:-1] >= y[2:])) + 1
    i = i[np.argsort(-y[i])][:n]
    out = []
    for k in i:
        a, b, c = y[k - 1], y[k], y[k + 1]
        den = a - 2 * b + c
        off = 0.5 * (a - c) / den if den < 0 else 0.0
        out.append(float(axis[k] + off * (axis[1] - axis[0])))
    return out
