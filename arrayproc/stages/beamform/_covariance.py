"""Spatial covariance matrices of element spectra, for the adaptive and subspace beamformers
(``mvdr``, ``music``, ``lr_cbf`` with adaptive weights).

Per bin f the sample covariance of ``K`` consecutive snapshots (the ``snapshots`` key),

    R̂(f) = (1/K) Σ_k x_k(f) x_k(f)^H,

x_k the element DFTs of snapshot k (unnormalised, numpy sign convention, as :mod:`cbf`), so a
plane wave of DFT amplitude s gives R̂ = |s|² a a^H with a_n = exp(+j2πf τ_n). Groups of K
snapshots are disjoint and aligned on the absolute snapshot grid (snapshot number = first
sample // hop, a multiple of K starts a group), as the ``integrate`` stage does, so a run
started anywhere forms the same groups; a group with a missing snapshot is dropped.

Also here: forward-backward averaging (centro-symmetric arrays), spatial smoothing (uniform
line arrays) and diagonal loading relative to the mean element power.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from arrayproc.chain import Stage
from arrayproc.chain.block import Block
from arrayproc.chain.domains import Domain
from arrayproc.dsp import workers
from arrayproc.errors import ConfigError
from arrayproc.stages.beamform._common import SpectraFramer


@dataclass
class CovarianceGroup:
    """One covariance estimate: ``r`` (F, C, C) complex128 over ``k`` snapshots, the mean
    centre time and circular-mean heading (deg) of the snapshots, the block they came from
    (for positions, pose and frequencies), and the span of their frames (s)."""

    r: np.ndarray
    k: int
    time: float
    heading: float
    t0: float
    span: float
    block: Block


def _circ_mean_deg(a: np.ndarray) -> float:
    r = np.deg2rad(np.asarray(a, float))
    return float(np.mod(np.rad2deg(np.arctan2(np.sin(r).mean(), np.cos(r).mean())), 360.0))


def covariance_groups(stage: Stage, blocks: Iterator[Block], snapshots: int, nfft: int,
                      hop: int, window: str, band: tuple[float, float] | None,
                      threads: int = 1) -> Iterator[CovarianceGroup]:
    """The sample covariance of every complete group of ``snapshots``
    snapshots of the stage's input (time blocks, framed here, or element-spectra blocks).

    A group's spectra are kept (K·F·C complex64, e.g. 25 MB for 64 snapshots of 761 bins and
    64 channels) and multiplied out at once when it is complete (:func:`accumulate`), so the
    result does not depend on how the input was cut into blocks (segmented runs equal whole
    ones)."""
    rec = stage.ctx.recording
    nav = rec.nav if rec is not None else None
    framer = SpectraFramer(nfft, hop, window, band, nav)
    buf: np.ndarray | None = None  # the group's spectra (K, F, C), filled row by row
    n_in = 0  # snapshots in buf
    group, expected, valid = -1, 0, False
    times: list[float] = []
    heads: list[float] = []
    first_start = 0.0
    key = None
    count = 0  # running snapshot number when the input carries no sample grid
    for b in blocks:
        spec = _spectra(stage, framer, b)
        if spec is None:
            continue
        m = spec.meta
        if m.starts is not None and m.hop:
            ks = np.asarray(m.starts, np.int64) // int(m.hop)
        else:
            ks = count + np.arange(spec.data.shape[0], dtype=np.int64)
        count = int(ks[-1]) + 1
        geo = (spec.positions.tobytes(), spec.freqs.tobytes())
        if geo != key:
            group, key, buf = -1, geo, None  # geometry or bins changed: start afresh
        x = spec.data
        for i in range(x.shape[0]):
            k = int(ks[i])
            g = k // snapshots
            if g != group:
                group, expected, valid, n_in = g, g * snapshots, True, 0
                times, heads = [], []
            if k != expected:
                valid = False  # a snapshot of this group is missing: the group is dropped
            expected = k + 1
            if not valid:
                continue
            if buf is None:
                buf = np.empty((snapshots,) + x.shape[1:], np.complex64)
            if n_in == 0:
                first_start = float(m.times[i]) - 0.5 * float(m.nfft) / spec.fs
            buf[n_in] = x[i]
            n_in += 1
            times.append(float(m.times[i]))
            heads.append(float(m.headings[i]))
            if n_in == snapshots:
                acc = np.zeros((x.shape[1], x.shape[2], x.shape[2]), np.complex128)
                accumulate(acc, buf, threads)
                span = times[-1] + 0.5 * float(m.nfft) / spec.fs - first_start
                yield CovarianceGroup(acc / snapshots, snapshots, float(np.mean(times)),
                                      _circ_mean_deg(heads), first_start, span, spec)
                valid = False


def accumulate(acc: np.ndarray, x: np.ndarray, threads: int = 1) -> None:
    """``acc`` (F, C, C) += Σ_s x_s x_s^H for the snapshots ``x`` (S, F, C): per bin one
    complex64 GEMM (F, C, S) @ (F, S, C) (BLAS reads the transposed operand in place), added
    to the complex128 accumulator; the bins split over ``threads`` workers (the GEMMs release
    the GIL). Single-precision products: their rounding (~1e-7 of the largest element) is far
    below the sampling error of any covariance estimate (~1/√K) and below the loading."""
    xf = np.ascontiguousarray(x.transpose(1, 0, 2), np.complex64)  # (F, S, C)
    nf = xf.shape[0]

    def run(sl: slice) -> None:
        part = xf[sl]
        acc[sl] += part.transpose(0, 2, 1) @ part.conj()

    # always on the pool's workers, even one: they run single-threaded BLAS, where OpenBLAS's
    # own threads in the calling thread cost 10x the CPU time on a loaded machine (measured)
    n_thr = max(1, min(threads, nf // 64))  # as _covstage.BINS_PER_THREAD
    edges = [nf * k // n_thr for k in range(n_thr + 1)]
    list(workers.pool(n_thr).map(run, [slice(edges[k], edges[k + 1]) for k in range(n_thr)]))


def _spectra(stage: Stage, framer: SpectraFramer, b: Block) -> Block | None:
    """Element spectra of one input block (time blocks framed, spectra blocks as they are)."""
    if b.domain is Domain.TIME:
        if np.iscomplexobj(b.data):
            raise ConfigError(f"stage {stage.name!r}: needs a real time series (complex "
                              "baseband input is not supported)")
        return framer.push(b)
    if b.domain is Domain.SPECTRA:
        return b
    raise ConfigError(f"stage {stage.name!r}: needs time or element-spectra input, got "
                      f"{b.domain}")


def exchange(positions: np.ndarray, tol: float = 1e-6) -> np.ndarray | None:
    """The exchange permutation J of a centro-symmetric array: ``perm[i]`` is the element at
    −r_i (positions relative to the centroid), or None when the array is not centro-symmetric
    (forward-backward averaging needs it)."""
    p = np.asarray(positions, float)
    rel = p - p.mean(axis=0)
    d = np.abs(rel[:, None, :] + rel[None, :, :]).max(axis=2)
    match = np.argmin(d, axis=1)
    scale = max(float(np.abs(rel).max()), 1.0)
    idx = np.arange(len(p))
    if np.any(d[idx, match] > tol * scale) or np.any(match[match] != idx):
        return None
    return match


def forward_backward(r: np.ndarray, perm: np.ndarray) -> np.ndarray:
    """Forward-backward average R_fb = ½ (R + J R* J) (Pillai 1989): for a
    centro-symmetric array J a* = a (phase centre at the centroid), so every plane-wave term is
    kept and the cross terms of coherent sources are decorrelated."""
    return 0.5 * (r + r[..., perm[:, None], perm[None, :]].conj())


def spatial_smoothing(r: np.ndarray, order: np.ndarray, subarrays: int) -> np.ndarray:
    """Forward spatial smoothing (Shan, Wax & Kailath 1985): the mean of the covariances
    of ``subarrays`` overlapping subarrays of L = C − subarrays + 1 consecutive elements of a
    uniform line array (``order``: channels from the forward end aft). Returns (F, L, L) in the
    element order of ``order``; M coherent sources need subarrays ≥ M (and L > M)."""
    c = order.size
    size = c - subarrays + 1
    if size < 2:
        raise ConfigError(f"spatial smoothing over {subarrays} subarrays leaves fewer than 2 "
                          f"elements of {c}")
    ro = r[..., order[:, None], order[None, :]]
    out = np.zeros(r.shape[:-2] + (size, size), r.dtype)
    for s in range(subarrays):  # a handful of subarrays: one slice sum each
        out += ro[..., s:s + size, s:s + size]
    return out / subarrays


def load_diagonal(r: np.ndarray, loading: float) -> np.ndarray:
    """R + ε σ̄² I with σ̄² = tr R / C the mean element power per bin (loading ``ε`` relative,
    Carlson 1988): the same ε means the same white-noise floor whatever the level."""
    c = r.shape[-1]
    sigma = np.real(np.trace(r, axis1=-2, axis2=-1)) / c  # (F,)
    out = r.copy()
    idx = np.arange(c)
    out[..., idx, idx] += (loading * sigma)[..., None]
    return out
