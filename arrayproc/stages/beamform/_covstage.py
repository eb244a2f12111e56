"""The base of the beamformers that work on covariance matrices (``mvdr``, ``music``): the keys
they share with ``cbf`` (nfft, hop, window, band, beams) plus ``snapshots`` and ``output``,
the covariance groups (:mod:`_covariance`), and power blocks out.

Output: float32 blocks of domain ``POWER`` ``("snapshot", "freq", "beam")``, one row per
covariance group, ``meta.integration = Integration(snapshots, "blockwise", mean=True)`` (a
covariance is a mean over its snapshots), times the mean centre time of the group's snapshots
and headings their circular mean. ``output = "bins"`` keeps every bin; ``"broadband"`` sums
the bins (incoherent over frequency) into one bin at the band's centre whose ``df`` is the
band's width, so ``btr`` and ``bearings`` read it like any power block. ``integrate`` (more
groups), ``btr``, ``lofar`` and ``bearings`` follow unchanged.
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Callable, Iterator

import numpy as np

from arrayproc.chain import Param, Stage, positive
from arrayproc.chain.block import Block
from arrayproc.chain.domains import Domain, Integration, SnapshotMeta
from arrayproc.dsp import workers
from arrayproc.errors import ConfigError
from arrayproc.geo.beams import beam_directions
from arrayproc.stages.beamform._covariance import CovarianceGroup, covariance_groups
from arrayproc.stages.beamform._steering import Steering
from arrayproc.stages.beamform.cbf import WINDOWS

COMMON = {
    "nfft": Param("int", 1024, "samples per snapshot (DFT length)", check=positive),
    "hop": Param("int", 0, "samples between snapshots (0: nfft/2)"),
    "window": Param("str", "hann", "time taper of each snapshot", choices=WINDOWS),
    "band": Param("band", None, "[lo, hi] Hz of the bins (default: all)"),
    "beams": Param("table", {"start": 0.0, "stop": 180.0, "count": 181},
                   "cone angles {start, stop, count} or {bearings, elevations}, deg"),
    "snapshots": Param("int", 32, "snapshots per covariance estimate (disjoint groups)",
                       check=positive),
    "output": Param("str", "bins", "per-bin power or its sum over the bins",
                    choices=("bins", "broadband")),
    "threads": Param("int", 0, "worker threads, each on a part of the bins (0: all cores)"),
}


class CovarianceStage(Stage):
    """Base of ``mvdr`` and ``music``: subclasses implement :meth:`spectrum`."""

    accepts = frozenset({Domain.TIME, Domain.SPECTRA})
    produces = Domain.POWER

    def validate(self) -> None:
        w = f"stage {self.name!r}"
        if self.hop == 0:
            self.hop = max(1, self.nfft // 2)
        if self.hop < 0:
            raise ConfigError(f"{w}: key 'hop' must be > 0, got {self.hop}")
        if self.hop > self.nfft:
            warnings.warn(f"{w}: key 'hop' ({self.hop}) exceeds 'nfft' ({self.nfft}): each "
                          f"snapshot skips {self.hop - self.nfft} samples", stacklevel=2)
        if self.threads < 0:
            raise ConfigError(f"{w}: key 'threads' must be >= 0, got {self.threads}")
        if self.band is not None and self.band[0] < 0:
            raise ConfigError(f"{w}: key 'band' must be >= 0 Hz, got {self.band}")
        try:
            self.beam_axis, self._dirs, self.beam_mode = beam_directions(self.beams)
        except ConfigError as e:
            raise ConfigError(f"{w}: {e}") from None
        self._key = None

    # -- per stream set-up ---------------------------------------------------------------
    def prepare(self, positions: np.ndarray, freqs: np.ndarray) -> None:
        """(Re)build what depends on the geometry and the bins (subclasses extend it)."""
        self.steering = Steering(positions, self._dirs, self.beam_mode, freqs,
                                 self.ctx.sound_speed)

    def spectrum(self, r: np.ndarray, bins: slice) -> np.ndarray:
        """Power (f, B) of the covariance ``r`` (f, C, C) of the bins ``bins``."""
        raise NotImplementedError

    def split_bins(self, fn: Callable[[slice], None], nf: int) -> None:
        """Run ``fn(bins)`` on ``threads`` contiguous parts of the bins, on the pool's workers
        (single-threaded BLAS each; numpy's batched linear algebra and the kernels release the
        GIL). Even one part goes to a worker: OpenBLAS's own threads in the calling thread
        cost several times the CPU time on a loaded machine (measured)."""
        n_thr = max(1, min(workers.count(self.threads), nf // 8))
        edges = [nf * i // n_thr for i in range(n_thr + 1)]
        parts = [slice(edges[i], edges[i + 1]) for i in range(n_thr)]
        list(workers.pool(n_thr).map(fn, parts))

    # -- compute -----------------------------------------------------------------------
    def _group_power(self, g: CovarianceGroup) -> np.ndarray:
        b = g.block
        key = (b.positions.tobytes(), b.freqs.tobytes(), self.ctx.sound_speed)
        if key != self._key:
            self._key = key
            self.prepare(b.positions, b.freqs)
        nf = g.r.shape[0]
        out = np.empty((nf, self._dirs.shape[0]))

        def run(bins: slice) -> None:
            out[bins] = self.spectrum(g.r[bins], bins)

        self.split_bins(run, nf)
        return out

    def process(self, blocks: Iterator[Block]) -> Iterator[Block]:
        index = 0
        for g in covariance_groups(self, blocks, self.snapshots, self.nfft, self.hop,
                                   self.window, None if self.band is None else tuple(self.band),
                                   workers.count(self.threads)):
            p = self._group_power(g)
            b = g.block
            freqs, df = b.freqs, float(b.meta.df)
            if self.output == "broadband":
                p = p.sum(axis=0, keepdims=True)
                freqs = np.array([0.5 * (b.freqs[0] + b.freqs[-1])])
                df = float(b.freqs[-1] - b.freqs[0]) + df
            m = b.meta
            meta = SnapshotMeta(np.array([g.time]), np.array([g.heading]), m.nfft, m.hop,
                                m.window, df, starts=None, beam_mode=self.beam_mode,
                                integration=Integration(g.k, "blockwise", True))
            yield dataclasses.replace(
                b, data=p[None].astype(np.float32), domain=Domain.POWER, t0=g.t0, span=g.span,
                freqs=freqs, beams=self.beam_axis, index=index, meta=meta)
            index += 1

    def warmup_seconds(self, fs: float) -> float:
        return (self.snapshots * self.hop + self.nfft) / fs

    def snapshot_seconds(self) -> float | None:
        return self.snapshots * self.hop / self.fs_in if self.fs_in else None
