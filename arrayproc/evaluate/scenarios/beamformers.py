"""Beamformer set-ups and closed forms (docs/validation/beamformers.md): MVDR against
Sherman-Morrison, root-MUSIC against the stochastic CRB, port/starboard rejection of twin and
triplet arrays, and the simulated triplet recording of the L-R chain.

- :func:`exact_cov`, :func:`closed_form` — one interferer's exact covariance and the Capon
  estimate, white-noise gain and output power with diagonal loading (Sherman-Morrison).
- :func:`resolved`, :func:`local_peaks` — the two-source resolution criterion.
- :func:`stochastic_crb`, :func:`root_trials`, :func:`rmse_ratio` — root-MUSIC RMSE over the
  stochastic CRB (Stoica & Nehorai 1990).
- :func:`source_spectra`, :func:`rejection_closed_form` — one horizontal plane wave and the
  look-over-mirror power ratio of the L-R weights.
- :data:`LR_TRIPLET_SCENARIO` — the triplet recording with one broadband source.
- :class:`Products`, :class:`Rows` — an in-memory stand-in for a products writer, for stages
  run outside a chain.

The signals are :mod:`arrayproc.sim.snapshot_spectra`.
"""

from __future__ import annotations

import numpy as np

from arrayproc.chain.stage import RunContext
from arrayproc.sim.snapshot_spectra import C, blocks, spectra, steer
from arrayproc.stages.beamform.cbf import element_delays
from arrayproc.stages.beamform.music import MUSIC

__all__ = ["LR_TRIPLET_SCENARIO", "Products", "Rows", "closed_form", "exact_cov",
           "local_peaks", "rejection_closed_form", "resolved", "rmse_ratio", "root_trials",
           "source_spectra", "stochastic_crb"]


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


def exact_cov(pos, f, cone_i, inr, sigma2=1.0):
    """R = σ² I + σ_i² v v^H of one interferer at ``cone_i`` and its steering vector."""
    v = steer(pos, cone_i, np.array([f]))[0]
    s2 = sigma2 * 10 ** (inr / 10)
    return sigma2 * np.eye(pos.shape[0]) + s2 * np.outer(v, v.conj()), v, s2


def closed_form(a, v, s2, sigma2, delta):
    """Sherman-Morrison for R + δI = (σ²+δ) I + s² v v^H: the Capon estimate 1/a^H R_δ⁻¹ a,
    the white-noise gain of w = R_δ⁻¹ a / a^H R_δ⁻¹ a and its output power w^H R w."""
    n = a.size
    rho = np.vdot(v, a)
    beta = s2 / (sigma2 + delta + n * s2)
    ainv_a = (n - beta * abs(rho) ** 2) / (sigma2 + delta)
    wn = (a - beta * v * rho) / (sigma2 + delta) / ainv_a  # weights
    wng = abs(np.vdot(wn, a)) ** 2 / np.vdot(wn, wn).real
    out = sigma2 * np.vdot(wn, wn).real + s2 * abs(np.vdot(wn, v)) ** 2
    return 1.0 / ainv_a, wng, out


def resolved(p: np.ndarray, axis: np.ndarray, truth, tol: float = 0.3) -> bool:
    """Both of the two strongest peaks of ``p`` within ``tol`` deg of the sorted truth."""
    pk = sorted(local_peaks(p, axis, 2))
    return len(pk) == 2 and all(abs(a - b) <= tol for a, b in zip(pk, truth, strict=True))


def stochastic_crb(pos, f, cones, snr_db, snapshots):
    """Stochastic (unconditional) CRB of the cone angles, rad² (Stoica & Nehorai 1990):
    σ²/(2K) {Re[(D^H Π⊥ D) ⊙ (P A^H R⁻¹ A P)ᵀ]}⁻¹, uncorrelated sources of power P = SNR·σ²,
    σ² = 1."""
    fr = np.array([f])
    a = np.stack([steer(pos, c, fr)[0] for c in cones], 1)  # (C, M)
    x = pos[:, 0] - pos[:, 0].mean()
    d = np.stack([a[:, i] * (-2j * np.pi * f * x * np.sin(np.deg2rad(c)) / C)
                  for i, c in enumerate(cones)], 1)
    p = 10 ** (snr_db / 10) * np.eye(len(cones))
    r = a @ p @ a.conj().T + np.eye(pos.shape[0])
    proj = np.eye(pos.shape[0]) - a @ np.linalg.solve(a.conj().T @ a, a.conj().T)
    h = (d.conj().T @ proj @ d) * (p @ a.conj().T @ np.linalg.solve(r, a) @ p).T
    return np.diag(np.linalg.inv(h.real)) / (2 * snapshots)


def root_trials(pos, f, cones, snr_db, snapshots, trials, seed, **kw):
    """Root-MUSIC cone angles (trials, M) of independent trials (one covariance group each)."""
    rng = np.random.default_rng(seed)
    fr = np.array([f])
    x = spectra(pos, fr, cones, snr_db, trials * snapshots, rng)
    st = MUSIC(beams={"start": 0.0, "stop": 180.0, "count": 19}, snapshots=snapshots,
               sources=len(cones), root=True, **kw)
    st.ctx = RunContext(products=Products())
    for _ in st.process(blocks(x, fr, pos, per_block=snapshots)):
        pass
    g = st.ctx.products.groups["music"]
    t, cone = g.column("time"), g.column("cone_deg")
    out = np.full((trials, len(cones)), np.nan)
    for i, tt in enumerate(np.unique(t)):
        out[i, :] = np.sort(cone[t == tt])[: len(cones)]
    return out


def rmse_ratio(pos: np.ndarray, f: float, cones, snr_db: float, snapshots: int,
               trials: int, seed: int) -> np.ndarray:
    """Root-MUSIC RMSE per source over the root of the stochastic CRB."""
    est = root_trials(pos, f, cones, snr_db, snapshots, trials, seed)
    err = np.deg2rad(est - np.sort(cones)[None])
    rmse = np.sqrt(np.nanmean(err**2, axis=0))
    crb = np.sqrt(stochastic_crb(pos, f, sorted(cones), snr_db, snapshots))
    return rmse / crb


def source_spectra(pos, freqs, rel_deg, snr, k, rng):
    """(K, F, C): a complex Gaussian plane wave from relative bearing ``rel_deg`` (horizontal)
    at per-element SNR ``snr`` (linear) in unit white noise."""
    d = np.array([[np.cos(np.deg2rad(rel_deg)), np.sin(np.deg2rad(rel_deg)), 0.0]])
    a = np.exp(2j * np.pi * freqs[:, None] * element_delays(pos, d, "3d", C)[0][None])
    c = pos.shape[0]
    x = (rng.standard_normal((k, freqs.size, c)) + 1j * rng.standard_normal((k, freqs.size, c)))
    s = (rng.standard_normal((k, freqs.size)) + 1j * rng.standard_normal((k, freqs.size)))
    return (x + np.sqrt(snr) * s[..., None] * a[None]) / np.sqrt(2)


def rejection_closed_form(n, q, snr, gamma):
    """Look over mirror beam power of a source at per-element SNR ``snr`` in unit white noise
    for the weights (a − γρ a_m)/(1 − γ|ρ|²) (scaled by N): look N² s + ‖w‖², mirror
    N² |ρ|² (1 − γ)²/(1 − γ|ρ|²)² s + ‖w‖², ‖w‖² = N (1 − 2γ|ρ|² + γ²|ρ|²)/(1 − γ|ρ|²)².
    γ = 0 is delay-and-sum, (N s + 1)/(N |ρ|² s + 1); γ = 1 the full null, 1 + N(1 − |ρ|²) s."""
    norm = n * (1 - 2 * gamma * q + gamma**2 * q) / (1 - gamma * q) ** 2
    mirror = n * n * q * (1 - gamma) ** 2 / (1 - gamma * q) ** 2 * snr
    return 10 * np.log10((n * n * snr + norm) / (mirror + norm))


LR_TRIPLET_SCENARIO = """
[recording]
fs = 4096.0
duration = 8.0
seed = 3
[array]
type = "triplet"
n = 16
spacing = 0.75
radius = 0.1
depth = 60.0
[ownship]
heading = 30.0
[propagation]
loss = "spherical"
[noise]
level_db = 60.0
[[source]]
name = "target"
start = [2000.0, 0.0]
depth = 60.0
course = 0.0
speed_kn = 0.0
[source.broadband]
band = [500.0, 1500.0]
level_db = 126.0
"""
