"""Propagation set-up: the array's pose per sample, exact reference retarded times and the
transmission-loss laws handed to the numba kernels (``arrayproc.sim._propagate_kernels``).

Retarded time at the array reference point (thesis eq. (2.47), exact): τ solves
c·τ = |x_R(t) − x_S(t − τ)|, found by fixed-point iteration (contraction |v_S|/c < 0.01), to
1e-12 s. The kernels refine it per element (Newton, exact geometry).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from arrayproc.acoustics.tl.table import TLTable
from arrayproc.sim.scenario import Propagation

N_ITER = 10  # fixed (never data-dependent, so results do not depend on chunking)
GRID = 32  # samples between exact reference retarded times


@dataclass
class PoseTrack:
    """Array pose at sample times: reference (x, y) (n, 2), depth (n,), sin/cos of heading,
    lateral offset (n,) of every element (m, starboard); ``epos`` (n, ch, 3) element world
    positions of a bending array (zero rows: rigid, built from the rest by the kernels)."""

    rpos: np.ndarray
    rdepth: np.ndarray
    sin_h: np.ndarray
    cos_h: np.ndarray
    lateral: np.ndarray
    epos: np.ndarray = field(default_factory=lambda: np.zeros((0, 1, 3)))

    def window(self, i0: int, i1: int) -> PoseTrack:
        """Samples [i0, i1) of the pose."""
        return PoseTrack(self.rpos[i0:i1], self.rdepth[i0:i1], self.sin_h[i0:i1],
                         self.cos_h[i0:i1], self.lateral[i0:i1],
                         self.epos[i0:i1] if self.epos.shape[0] else self.epos)

    @property
    def ref3(self) -> np.ndarray:
        return np.column_stack([self.rpos, self.rdepth])


def retarded_time(receiver: np.ndarray, t: np.ndarray, mover, c: float) -> np.ndarray:
    """τ (n,) with c·τ = |receiver[k] − x_S(t[k] − τ)| for a mover with ``state3``.

    Fixed-point iteration, a fixed number of times: the error shrinks by |v_S|/c per step
    (< 0.01), from ≤ τ·|v_S|/c, so 10 steps leave < 1e-15 s for ship speeds."""
    tau = np.linalg.norm(receiver - mover.state3(t)[0], axis=1) / c
    if getattr(mover, "is_static", False):  # a fixed point: exact at once
        return tau
    for _ in range(N_ITER):
        tau = np.linalg.norm(receiver - mover.state3(t - tau)[0], axis=1) / c
    return tau


def forward_time(emit_pos: np.ndarray, t_emit: np.ndarray, mover, c: float) -> np.ndarray:
    """Arrival time t_a > t_emit at a mover: c·(t_a − t_emit) = |x_M(t_a) − emit_pos|."""
    ta = t_emit + np.linalg.norm(mover.state3(t_emit)[0] - emit_pos, axis=1) / c
    for _ in range(N_ITER):
        ta = t_emit + np.linalg.norm(mover.state3(ta)[0] - emit_pos, axis=1) / c
    return ta


def grid_nodes(k0: int, k1: int, fs: float) -> np.ndarray:
    """Times (s) of the absolute grid nodes (multiples of GRID samples) spanning [k0, k1)."""
    g0 = (k0 // GRID) * GRID
    g1 = ((k1 - 1) // GRID + 1) * GRID
    return np.arange(g0, g1 + 1, GRID) / fs


class LossLaw:
    """Transmission loss as the kernels want it: mode, transition range, gain table.

    spherical: TL = 20 log10 r; cylindrical: 20 log10 r up to r_t, then
    20 log10 r_t + 10 log10(r / r_t); table: TL(range) for the source/receiver depth pair,
    linear in dB between the table's ranges, tabulated as an amplitude gain every ≤ 1 m.
    """

    def __init__(self, prop: Propagation) -> None:
        self.prop = prop
        self._table = TLTable.load(prop.table_path) if prop.table_path else None
        self._cache: dict[tuple[float, float], tuple[np.ndarray, float, float]] = {}

    @property
    def mode(self) -> int:
        return {"spherical": 0, "cylindrical": 1, "table": 2}[self.prop.loss]

    def tl_db(self, r: np.ndarray, src_depth: float, rcv_depth: float) -> np.ndarray:
        """TL (dB) at ranges r (m), as the kernels apply it."""
        r = np.maximum(np.asarray(r, dtype=float), 1.0)
        if self.mode == 0:
            return 20 * np.log10(r)
        if self.mode == 1:
            rt = self.prop.transition_range
            return np.where(r <= rt, 20 * np.log10(r), 10 * np.log10(rt * r))
        gtab, r0, dr = self.gain_table(src_depth, rcv_depth)
        x = np.clip((r - r0) / dr, 0, gtab.size - 1)
        return -20 * np.log10(np.interp(x, np.arange(gtab.size), gtab))

    def gain_table(self, src_depth: float, rcv_depth: float) -> tuple[np.ndarray, float, float]:
        """(gain (n,), r0, dr): amplitude gain 10^(−TL/20) on a uniform range grid."""
        if self.mode != 2:
            return np.zeros(2), 0.0, 1.0
        key = (float(src_depth), float(rcv_depth))
        if key not in self._cache:
            table = self._table
            rr = table.range_m if table is not None else self.prop.table_range

            def tl_fn(r: np.ndarray) -> np.ndarray:
                if table is not None:
                    return table(r, src_depth, rcv_depth)
                return np.interp(r, self.prop.table_range, self.prop.table_tl)
            dr = min(1.0, float(np.min(np.diff(rr))) / 4.0)
            r0 = float(rr[0])
            grid = r0 + dr * np.arange(int(np.ceil((rr[-1] - r0) / dr)) + 1)
            self._cache[key] = (np.ascontiguousarray(10 ** (-tl_fn(grid) / 20.0)), r0, dr)
        return self._cache[key]

    def kernel_args(self, src_depth: float, rcv_depth: float) -> tuple:
        """(amp_mode, r_t, gtab, g_r0, g_dr) for the kernels."""
        gtab, r0, dr = self.gain_table(src_depth, rcv_depth)
        return self.mode, float(self.prop.transition_range), gtab, r0, dr
