"""``cbf_azel``: conventional beamformer over an azimuth × elevation grid, for volumetric and
planar arrays (any geometry), as band power per snapshot.

For each snapshot (``nfft`` samples every ``hop``, taper ``window``) the stage returns, for
every direction d of the grid, the CBF power of eq. (2.8) of :mod:`cbf` summed over the bins of
``band`` (unshaded, w_n = 1)::

    P(d) = Σ_f |Σ_n X_n(f) e^{−j2πf τ_n(d)}|²,        τ_n(d) = (r_n − r̄)·k(d)/c      (1)

with k(d) the unit vector towards the source. Expanded over element pairs (m < n)::

    P(d) = Σ_n Σ_f |X_n|² + 2 Σ_{m<n} Re ρ_mn(Δ_mn(d)),
    ρ_mn(Δ) = Σ_f X_m X_n* e^{−j2πfΔ},   Δ_mn(d) = (r_m − r_n)·k(d)/c                     (2)

so the direction enters only through one lag per pair: ρ_mn is the band-limited cross-
correlation of the pair. Each snapshot's ρ_mn is evaluated on a lag grid of step δ covering
±max |r_m − r_n|/c by one real GEMM over all pairs and snapshots of a batch, then read at
Δ_mn(d) by four-point Lagrange interpolation (numba kernel
:func:`_azel_kernels.azel_power`). Interpolation error bound (Lagrange remainder, ρ'''' ≤
ω_max⁴ Σ_f|X_m||X_n|)::

    |error| ≤ (9/384) (ω_max δ)⁴ · Σ_f (Σ_n |X_n|)²                                    (3)

i.e. at most ``accuracy`` times the power of a perfectly coherent plane wave (the largest
power the snapshot can give); δ is chosen from ``accuracy`` and the band's top frequency.
The cost per snapshot is pairs × lags × bins for the GEMM plus pairs × directions for the
grid, against channels × directions × bins for eq. (1) directly (``azel_power_reference``).
The snapshots of a batch that share one heading go through one GEMM and one kernel call
(a fixed or bottom-mounted array: the whole batch); a heading that changes from snapshot to
snapshot costs one call per snapshot (slower, same result). ``scripts/bench_azel.py`` times it.

Directions: ``azimuth = [lo, hi, step]`` deg, true azimuth clockwise from north, turned into
the body frame with the array heading of each snapshot (the recording's navigation, else the
block pose); an array with neither (no heading) gets azimuths relative to its body x axis
(forward), clockwise seen from above (towards starboard). A span of 360° or more is taken as
the full circle (the endpoint ``hi`` is dropped as a copy of ``lo``). ``elevation = [lo, hi,
step]`` deg, positive up (above the horizontal), in [−90, 90]: the body frame's z points
down, so k = (cos e cos β, cos e sin β, −sin e) with β = azimuth − heading. Roll and pitch
are taken as zero.

Output: blocks of domain POWER ``("snapshot", "freq", "beam")`` float32 with one frequency
cell (the band: ``freqs`` holds its centre, ``meta.df`` its width) and the directions on the
beam axis, elevation-major (beam = i_el · n_az + i_az); ``beams`` is (D, 2) [azimuth,
elevation] deg and ``meta.beam_mode`` is ``"azel"``. ``integrate`` sums them like CBF power
and ``bearings`` picks the 2-D peaks.
"""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np

from arrayproc.chain import Param, Stage, positive, register
from arrayproc.chain.block import Block
from arrayproc.chain.domains import Domain, SnapshotMeta
from arrayproc.dsp.bands import check_nyquist
from arrayproc.dsp.blas_threads import set_local_threads
from arrayproc.errors import ConfigError
from arrayproc.stages.beamform._azel_kernels import azel_power
from arrayproc.stages.beamform._common import SpectraFramer
from arrayproc.stages.beamform.cbf import WINDOWS
from arrayproc.stages.beamform.checks import warn_spatial_aliasing

LAGRANGE4 = 9.0 / 384.0  # max |Π (u − u_i)| / 4! of four equispaced nodes, central interval


def _grid_key(v: list[float]) -> str | None:
    if len(v) != 3:
        return "expected [lo, hi, step] deg"
    if not v[2] > 0 or v[1] < v[0]:
        return "expected [lo, hi, step] with lo <= hi and step > 0"
    return None


def _elev_key(v: list[float]) -> str | None:
    msg = _grid_key(v)
    if msg is None and (v[0] < -90 or v[1] > 90):
        return "elevations must lie in [-90, 90] deg"
    return msg


def grid_axis(lo: float, hi: float, step: float, circular: bool) -> np.ndarray:
    """Grid values lo, lo + step, ... ≤ hi (deg); on a full circle the copy of lo at lo + 360
    is dropped."""
    n = int(math.floor((hi - lo) / step + 1e-9)) + 1
    v = lo + step * np.arange(n)
    if circular and hi - lo >= 360.0 - 1e-9:
        v = v[v < lo + 360.0 - 1e-9]
    return v


def world_directions(az_deg: np.ndarray, el_deg: np.ndarray) -> np.ndarray:
    """(n_el · n_az, 3) components (cos e cos a, cos e sin a, −sin e), elevation-major: the
    body-frame unit vector towards the source for heading 0 (north, east, down)."""
    e, a = np.meshgrid(np.deg2rad(el_deg), np.deg2rad(az_deg), indexing="ij")
    return np.stack([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), -np.sin(e)],
                    -1).reshape(-1, 3)


def lag_step(f_max: float, accuracy: float) -> float:
    """δ (s) with (9/384)(2π f_max δ)⁴ = accuracy (eq. 3)."""
    return (accuracy / LAGRANGE4) ** 0.25 / (2.0 * math.pi * max(f_max, 1e-9))


@register
class CBFAzEl(Stage):
    """Conventional beamformer over azimuth × elevation (band power); see module doc."""

    kind = "cbf_azel"
    accepts = frozenset({Domain.TIME})
    produces = Domain.POWER
    params = {
        "nfft": Param("int", 1024, "samples per snapshot (DFT length)", check=positive),
        "hop": Param("int", 0, "samples between snapshots (0: nfft/2)"),
        "window": Param("str", "hann", "time taper of each snapshot", choices=WINDOWS),
        "band": Param("band", None, "[lo, hi] Hz of the bins summed (default: all)"),
        "azimuth": Param("floats", [0.0, 360.0, 2.0], "[lo, hi, step] deg, true azimuth "
                         "clockwise from north (relative to body x without a heading)",
                         check=_grid_key),
        "elevation": Param("floats", [-90.0, 90.0, 2.0], "[lo, hi, step] deg, positive up",
                           check=_elev_key),
        "accuracy": Param("float", 1e-4, "bound of the lag interpolation error, a fraction "
                          "of a coherent plane wave's power (eq. 3)", check=positive),
        "batch": Param("int", 64, "snapshots per GEMM batch (and per output block)",
                       check=positive),
    }

    def validate(self) -> None:
        if self.hop == 0:
            self.hop = max(1, self.nfft // 2)
        if self.hop < 0:
            raise ConfigError(f"stage {self.name!r}: key 'hop' must be > 0, got {self.hop}")
        if self.band is not None and self.band[0] < 0:
            raise ConfigError(f"stage {self.name!r}: key 'band' must be >= 0 Hz")
        self.az = grid_axis(*self.azimuth, circular=True)
        self.el = grid_axis(*self.elevation, circular=False)
        self._grid = world_directions(self.az, self.el)
        e, a = np.meshgrid(self.el, self.az, indexing="ij")
        self.beam_axis = np.stack([a.ravel(), e.ravel()], -1)
        self._key = None

    def _prepare(self, spec: Block) -> None:
        """Pairs, baselines and the lag matrix for this stream's positions and bins."""
        key = (spec.positions.tobytes(), spec.freqs.tobytes(), self.ctx.sound_speed)
        if key == self._key:
            return
        self._key = key
        p = np.asarray(spec.positions, float)
        c = float(self.ctx.sound_speed)
        if p.shape[0] < 2:
            raise ConfigError(f"stage {self.name!r}: needs at least 2 hydrophones")
        warn_spatial_aliasing(f"stage {self.name!r}", p, float(spec.freqs.max()), c, "3d")
        m, n = np.triu_indices(p.shape[0], 1)
        self._pairs = (m, n)
        self._base = (p[m] - p[n]) / c  # (P, 3) s
        dmax = float(np.linalg.norm(self._base, axis=1).max())
        f = np.asarray(spec.freqs, float)
        step = lag_step(float(np.abs(f).max()), self.accuracy)
        n_lag = int(math.ceil(2.0 * dmax / step)) + 5
        self._lag0, self._dlag = -dmax - 2.0 * step, step
        lags = self._lag0 + step * np.arange(n_lag)
        ph = 2.0 * np.pi * f[:, None] * lags[None, :]
        # [Re G, Im G] @ [cos; sin] = Re Σ_f G e^{−j2πfΔ}   (eq. 2)
        self._lagmat = np.ascontiguousarray(np.vstack([np.cos(ph), np.sin(ph)]), np.float32)

    def pair_correlations(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(Re ρ (P, M, S) float32 on the lag grid, Σ_n Σ_f |X_n|² (S,)) of spectra (S, F, C)
        (eq. 2): one real GEMM of [Re G, Im G] against [cos; sin] over all pairs and
        snapshots, G = X_m X_n*."""
        m, n = self._pairs
        g = x[:, :, m] * np.conj(x[:, :, n])  # (S, F, P)
        n_s, n_p = x.shape[0], m.size
        ops = np.empty((n_p, n_s, 2 * x.shape[1]), np.float32)  # (P, S, 2F)
        gt = g.transpose(2, 0, 1)
        ops[:, :, :x.shape[1]] = gt.real
        ops[:, :, x.shape[1]:] = gt.imag
        old = set_local_threads(1)  # a small GEMM: threaded BLAS only adds contention
        try:
            rho = ops.reshape(n_p * n_s, -1) @ self._lagmat  # one 2-D GEMM: (P·S, M)
        finally:
            if old is not None:
                set_local_threads(old)
        auto = (x.real.astype(np.float64) ** 2 + x.imag.astype(np.float64) ** 2).sum((1, 2))
        return np.ascontiguousarray(rho.reshape(n_p, n_s, -1).transpose(0, 2, 1)), auto

    def power(self, x: np.ndarray, headings_deg: np.ndarray) -> np.ndarray:
        """Band power (S, D) float32 of spectra (S, F, C) at headings (S,) deg (eq. 2): the
        snapshots of each distinct heading in one kernel call (one call for a fixed array)."""
        heads = np.asarray(headings_deg, float)
        out = np.empty((x.shape[0], self._grid.shape[0]), np.float32)
        for h in np.unique(heads):
            sel = np.flatnonzero(heads == h)
            rho, auto = self.pair_correlations(x[sel])
            part = out if sel.size == x.shape[0] else np.empty((sel.size, out.shape[1]),
                                                                np.float32)
            azel_power(rho, self._lag0, self._dlag, self._base, auto, self._grid,
                       float(np.deg2rad(h)), part)
            if part is not out:
                out[sel] = part
        return out

    def process(self, blocks: Iterator[Block]) -> Iterator[Block]:
        rec = self.ctx.recording
        nav = rec.nav if rec is not None and getattr(rec, "nav", None) is not None \
            and rec.nav.time.size else None
        framer: SpectraFramer | None = None
        pend: list[Block] = []
        index = 0
        for b in blocks:
            if framer is None:
                check_nyquist(self.band, b.fs / 2, f"stage {self.name!r}")
                framer = SpectraFramer(self.nfft, self.hop, self.window,
                                       None if self.band is None else tuple(self.band), nav)
            spec = framer.push(b)
            if spec is None:
                continue
            pend.append(spec)
            if sum(s.data.shape[0] for s in pend) >= self.batch:
                out = self._emit(pend, index)
                index += out.data.shape[0]
                pend = []
                yield out
        if pend:
            yield self._emit(pend, index)

    def _emit(self, specs: list[Block], index: int) -> Block:
        """One POWER block of the snapshots of ``specs`` (element-spectra blocks)."""
        first, last = specs[0], specs[-1]
        self._prepare(first)
        x = np.concatenate([s.data for s in specs])
        times = np.concatenate([s.meta.times for s in specs])
        heads = np.concatenate([s.meta.headings for s in specs])
        starts = np.concatenate([s.meta.starts for s in specs])
        p = self.power(x, heads)
        f = first.freqs
        bin_df = first.fs / self.nfft
        width = float(f[-1] - f[0]) + bin_df
        meta = SnapshotMeta(times, heads, self.nfft, self.hop, self.window, width,
                            starts=starts, beam_mode="azel")
        fs = first.fs
        return Block(p[:, None, :], Domain.POWER, starts[0] / fs,
                     (starts[-1] - starts[0] + self.nfft) / fs, fs, first.positions,
                     last.pose, np.array([0.5 * (f[0] + f[-1])]), self.beam_axis, index, meta)

    def warmup_seconds(self, fs: float) -> float:
        return self.nfft / fs

    def snapshot_seconds(self) -> float | None:
        return self.hop / self.fs_in if self.fs_in else None


def azel_power_reference(x: np.ndarray, freqs: np.ndarray, positions: np.ndarray,
                         dirs: np.ndarray, c: float, chunk: int = 16) -> np.ndarray:
    """Eq. (1) in batched numpy: P (S, D) of spectra x (S, F, C) for body-frame unit vectors
    ``dirs`` (D, 3), by a complex matmul over bins and directions (chunks of ``chunk`` bins
    bound the (chunk, C, D) steering). The tests' and the benchmark's reference."""
    rel = np.asarray(positions, float) - np.asarray(positions, float).mean(axis=0)
    tau = (np.asarray(dirs, float) @ rel.T).T / c  # (C, D)
    out = np.zeros((x.shape[0], tau.shape[1]))
    for lo in range(0, len(freqs), chunk):
        f = np.asarray(freqs[lo:lo + chunk], float)
        a = np.exp(-2j * np.pi * f[:, None, None] * tau[None]).astype(np.complex64)
        y = np.matmul(x[:, lo:lo + chunk, None, :], a[None])[:, :, 0, :]  # (S, f, D)
        out += (y.real.astype(np.float64) ** 2 + y.imag ** 2).sum(axis=1)
    return out
