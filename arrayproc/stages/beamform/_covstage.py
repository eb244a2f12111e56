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
from collections.abc import Callable, Iterator

import numpy as np

from arrayproc.chain import Param, Stage, positive
from arrayproc.chain.block import Block
from arrayproc.chain.domains import Domain, Integration, SnapshotMeta
from arrayproc.dsp import workers
from arrayproc.stages.beamform._covariance import CovarianceGroup, covariance_groups
from arrayproc.stages.beamform._steering import Steering
from arrayproc.stages.beamform.cbf import WINDOWS, check_frame_keys

#: Fewest bins per worker thread: below, a second thread costs more CPU time than it saves
#: (MUSIC, 41 bins of 32 elements: 25 ms on two threads against 18 ms on one, measured).
BINS_PER_THREAD = 64

COMMON = {
    "nfft": Param("int", 1024, "samples per snapshot (DFT length)", check=positive, unit="samples"),
    "hop": Param("int", 0, "samples between snapshots (0: nfft/2)", unit="samples"),
    "window": Param("str", "hann", "time taper of each snapshot", choices=WINDOWS),
    "band": Param("band", None, "[lo, hi] Hz of the bins (default: all)", unit="Hz"),
    "beams": Param("table", {"start": 0.0, "stop": 180.0, "count": 181},
                   "cone angles {start, stop, count} or {bearings, elevations}, deg", unit="deg"),
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
        check_frame_keys(self)
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
        """Run ``fn(bins)`` on ``threads`` contiguous parts of at least ``BINS_PER_THREAD``
        bins, on the pool's workers
        (single-threaded BLAS each; numpy's batched linear algebra and the kernels release the
        GIL). Even one part goes to a worker: OpenBLAS's own threads in the calling thread
        cost several times the CPU time on a loaded machine (measured)."""
        n_thr = max(1, min(workers.count(self.threads), nf // BINS_PER_THREAD))
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

    def segment_grid(self, fs: float, n_channels: int) -> int:
        """Segment reads start on the covariance groups' grid (input samples), so a segment
        forms the groups of a single run (chain.segments)."""
        return int(self.snapshots * self.hop)

    def warmup_seconds(self, fs: float) -> float:
        return (self.snapshots * self.hop + self.nfft) / fs

    def snapshot_seconds(self) -> float | None:
        return self.snapshots * self.hop / self.fs_in if self.fs_in else None
