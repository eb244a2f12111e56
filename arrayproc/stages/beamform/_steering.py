"""Steering vectors of a beam fan and the Hermitian forms a(θ, f)^H Q(f) a(θ, f) that the
adaptive (MVDR: Q = R⁻¹) and subspace (MUSIC: Q = E_s E_s^H) beamformers evaluate on every
beam and bin.

The steering vector is the one :mod:`cbf` applies, a_n(θ, f) = exp(+j2πf τ_n(θ)) with τ_n the
plane-wave advance of element n over the centroid, so CBF is a^H x and the three stages agree
on directions. Two evaluations:

- *lag path*, for elements on a line (the body x axis, or cone beams, which see only x) at
  integer multiples of a spacing d (uniform line arrays, also with gaps or duplicated
  stations): a^H Q a = Σ_l s_l e^{jψl}, ψ = 2πf d u/c (u = cos θ), s_l the sums of Q over
  element pairs of co-array lag l (:func:`_adaptive_kernels.lag_sums`);
- *general path*, any geometry: batched GEMMs Q A, then Re Σ_n a_n* (Q a)_n, in chunks of bins.
"""

from __future__ import annotations

import copy

import numpy as np

from arrayproc.stages.beamform import _adaptive_kernels as ka
from arrayproc.stages.beamform.cbf import element_delays

CHUNK = 32  # bins per GEMM chunk of the general path (bounds the (chunk, C, B) steering)


def line_lags(positions: np.ndarray, cone: bool, tol: float = 1e-6
              ) -> tuple[np.ndarray, float] | None:
    """``(lag (C,) int64 ≥ 0, spacing d m)`` when the elements (their x only, for cone beams)
    lie on a line along body x at integer multiples of d; None otherwise."""
    p = np.asarray(positions, float)
    if not cone and (np.ptp(p[:, 1]) > tol or np.ptp(p[:, 2]) > tol):
        return None
    x = p[:, 0] - p[:, 0].min()
    ux = np.unique(np.round(x / tol) * tol)
    if ux.size < 2:
        return None
    d = float(np.min(np.diff(ux)))
    lag = np.round(x / d)
    if np.max(np.abs(lag * d - x)) > tol * max(1.0, float(x.max())):
        return None
    return lag.astype(np.int64), d


class Steering:
    """Steering of ``dirs`` (B, 3) body-frame unit vectors (``mode`` ``"cone"`` or ``"3d"``, as
    :func:`arrayproc.geo.beams.beam_directions`) for elements at ``positions`` (C, 3) m and
    bins ``freqs`` (F,) Hz; see module doc."""

    def __init__(self, positions: np.ndarray, dirs: np.ndarray, mode: str,
                 freqs: np.ndarray, sound_speed: float) -> None:
        self.positions = np.asarray(positions, float)
        self.freqs = np.asarray(freqs, float)
        self.n = self.positions.shape[0]
        self.tau = element_delays(self.positions, np.asarray(dirs, float), mode,
                                  sound_speed)  # (B, C) s
        lags = line_lags(self.positions, mode == "cone")
        self.lag: np.ndarray | None = None
        if lags is not None:
            self.lag, d = lags
            self.spacing = d
            self.psi = (2 * np.pi * d / sound_speed) * self.freqs[:, None] \
                * np.asarray(dirs, float)[None, :, 0]  # (F, B)
            self.n_lags = int(self.lag.max()) + 1

    def sub(self, bins: slice) -> Steering:
        """The same steering on the bins ``bins`` only (a shallow copy)."""
        out = copy.copy(self)
        out.freqs = self.freqs[bins]
        if self.lag is not None:
            out.psi = self.psi[bins]
        return out

    @property
    def lag_path(self) -> bool:
        return self.lag is not None

    def matrix(self, bins: slice | np.ndarray) -> np.ndarray:
        """Steering vectors (f, C, B) complex128 of the bins ``bins``: a_n = e^{j2πfτ_n}."""
        f = self.freqs[bins]
        return np.exp(2j * np.pi * f[:, None, None] * self.tau.T[None])

    def form(self, q: np.ndarray) -> np.ndarray:
        """a^H Q a (F, B) float64 for Hermitian ``q`` (F, C, C)."""
        nf = self.freqs.size
        out = np.empty((nf, self.tau.shape[0]))
        if self.lag_path:
            s = np.empty((nf, self.n_lags), np.complex128)
            ka.lag_sums(np.ascontiguousarray(q, np.complex128), self.lag, s)
            ka.lag_form(s, self.psi, out)
            return out
        for lo in range(0, nf, CHUNK):
            sl = slice(lo, min(nf, lo + CHUNK))
            a = self.matrix(sl)
            out[sl] = np.einsum("fcb,fcb->fb", a.conj(), q[sl] @ a).real
        return out

    def projections(self, u: np.ndarray) -> np.ndarray:
        """|u_i^H a|² (F, B, K) for the columns u_i of ``u`` (F, C, K) (eigenvectors)."""
        nf = self.freqs.size
        out = np.empty((nf, self.tau.shape[0], u.shape[2]))
        for lo in range(0, nf, CHUNK):
            sl = slice(lo, min(nf, lo + CHUNK))
            g = u[sl].conj().transpose(0, 2, 1) @ self.matrix(sl)  # (f, K, B)
            out[sl] = (g.real**2 + g.imag**2).transpose(0, 2, 1)
        return out


def form_reference(q: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Plain numpy a^H Q a (F, B) for steering ``a`` (F, C, B): the tests' reference."""
    return np.einsum("fcb,fcd,fdb->fb", a.conj(), q, a).real
