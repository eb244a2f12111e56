"""``tde``: delays of every channel relative to a reference channel → products ``delays``.

Per event block (from ``transients``) or per regular snapshot of ``nfft`` samples every ``hop``
(time blocks, for towed arrays). ``method = "xcorr"``: generalised cross-correlation, thesis
eqs. (3.26)-(3.27), with the ``weighting`` none / phat / scot / ml, the search limited to
|τ_i| ≤ |p_i − p_ref|/c + ``margin``, sub-sample peak by ``interp`` (``fft``: band-limited
maximum, the limit of the thesis's interpft; ``sinc``: windowed-sinc interpolation of the sampled
correlation, as accurate below 0.4 fs and cheaper, for per-snapshot use; ``parabolic``;
``none``) (:mod:`.gcc`).
``method = "unwrap"``: phase-unwrapping LLS, eqs. (3.30)-(3.36) with app. B (:mod:`.unwrap`).
σ per delay from the peak's curvature and the normalised correlation (:func:`.gcc.delay_sigma`).

Several sources at once (``peaks`` = K > 1, ``method = "xcorr"``): the K strongest peaks of
every channel pair (:mod:`.peaks`, written as a ``<name>_peaks`` group of kind
``delay_peaks`` with their σ, ρ and SNR), associated into sources by delay closure over the
triplets through the reference (:mod:`.closure`); each source gives one ``delays`` row, with
its ``source`` index (strongest first) and ``closure``. With K = 1 (the default) the rows are
those of the one-peak estimator, bit for bit.

Products ``delays`` (docs/formats.md): ``time`` (detection centre or snapshot centre, s),
``tau``, ``sigma`` (n, n_ch) s, ``corr`` (n, n_ch); group attr ``reference``. Yields one
delays block per row (:mod:`._common`) for the ``localise`` stage.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from arrayproc.chain import Param, Stage, positive, register
from arrayproc.chain.block import Block
from arrayproc.chain.domains import Domain
from arrayproc.dsp.framing import FrameBuffer
from arrayproc.errors import ConfigError

from ._common import DELAYS, DelaysMeta
from .closure import closure_hypotheses
from .gcc import INTERPS, WEIGHTINGS, GccEstimator
from .peaks import PAIR_WEIGHTINGS, PairPeakEstimator, all_pairs
from .unwrap import UnwrapEstimator


@register
class Tde(Stage):
    """Time-delay estimation between hydrophones (see the module docstring)."""

    kind = "tde"
    accepts = frozenset({Domain.EVENT, Domain.TIME})
    produces = DELAYS
    params = {
        "reference": Param("int", 0, "reference channel"),
        "band": Param("band", None, "band [lo, hi] Hz of the cross-spectrum (default: all)",
                      unit="Hz"),
        "method": Param("str", "xcorr", "xcorr or unwrap", choices=("xcorr", "unwrap")),
        "weighting": Param("str", "none", "GCC weighting", choices=WEIGHTINGS),
        "interp": Param("str", "fft", "sub-sample peak", choices=INTERPS),
        "margin": Param("float", 1e-4, "added to the geometric lag limit, s", unit="s"),
        "smooth_bins": Param("int", 9, "bins averaged for the scot/ml spectra",
                             check=positive, unit="bins"),
        "nfft": Param("int", None, "snapshot length for time blocks, samples", unit="samples"),
        "hop": Param("int", None, "snapshot hop for time blocks, samples (default nfft/2)",
                     unit="samples"),
        "unwrap_threshold": Param("float", 0.5, "app. B residual RMS threshold, rad",
                                  check=positive, unit="rad"),
        "unwrap_window": Param("int", 16, "app. B sliding window, bins", check=positive,
                               unit="bins"),
        "peaks": Param("int", 1, "correlation peaks kept per channel pair; > 1: several "
                       "sources per snapshot, associated by delay closure", check=positive),
        "max_sources": Param("int", None, "most sources per snapshot (default: peaks)",
                             check=positive),
        "min_closure": Param("float", 0.7, "least fraction of closed triplets of every source "
                             "after the first (peaks > 1)",
                             check=lambda v: None if 0 <= v <= 1 else "must be in [0, 1]"),
        "closure_sigmas": Param("float", 4.0, "closure tolerance in σ of the three delays "
                                "(peaks > 1)", check=positive),
        "closure_floor": Param("float", None, "added to the closure tolerance, s (default "
                               "0.2/B, B the band's width; peaks > 1)", unit="s"),
        "peak_separation": Param("float", None, "least lag between two peaks of a pair, s "
                                 "(default 1/B; peaks > 1)", unit="s"),
    }

    def validate(self) -> None:
        if self.nfft is not None and self.nfft < 16:
            raise ConfigError(f"stage {self.name!r}: key 'nfft': must be >= 16")
        if self.hop is not None and self.hop < 1:
            raise ConfigError(f"stage {self.name!r}: key 'hop': must be >= 1")
        if self.peaks > 1:
            if self.method != "xcorr":
                raise ConfigError(f"stage {self.name!r}: key 'peaks': several peaks need "
                                  "method = \"xcorr\"")
            if self.weighting not in PAIR_WEIGHTINGS:
                raise ConfigError(f"stage {self.name!r}: key 'weighting': several peaks take "
                                  f"{', '.join(PAIR_WEIGHTINGS)}, not {self.weighting!r}")
            if self.interp != "fft":
                raise ConfigError(f"stage {self.name!r}: key 'interp': several peaks are "
                                  "refined by \"fft\" only")

    def _estimator(self, n: int, fs: float, positions: np.ndarray):
        p = np.asarray(positions, float)
        if not 0 <= self.reference < p.shape[0]:
            raise ConfigError(f"stage {self.name!r}: key 'reference': {self.reference} outside "
                              f"0..{p.shape[0] - 1}")
        lim = np.linalg.norm(p - p[self.reference], axis=1) / self.ctx.sound_speed + self.margin
        if self.peaks > 1:
            pairs = all_pairs(p.shape[0])
            lag = (np.linalg.norm(p[pairs[:, 0]] - p[pairs[:, 1]], axis=1)
                   / self.ctx.sound_speed + self.margin)
            return PairPeakEstimator(n, fs, lag, pairs, p.shape[0], self.band, self.peaks,
                                     self.weighting, self.peak_separation, self.smooth_bins)
        if self.method == "unwrap":
            return UnwrapEstimator(n, fs, self.reference, self.band, self.unwrap_threshold,
                                   self.unwrap_window, 20, lim)
        return GccEstimator(n, fs, p.shape[0], self.reference, self.band, lim, self.weighting,
                            self.interp, self.smooth_bins)

    @staticmethod
    def _run(est, frames: np.ndarray):
        """Delays of the frames, or (peaks, estimator) for the several-source search."""
        got = est(frames)
        return (got, est) if isinstance(est, PairPeakEstimator) else got

    def _world(self, b: Block) -> np.ndarray:
        return b.pose.elements if b.pose is not None else np.asarray(b.positions, float)

    def process(self, blocks: Iterator[Block]) -> Iterator[Block]:
        out = self.products("delays", reference=self.reference)
        frames = None
        est = None
        for b in blocks:
            if b.domain == Domain.EVENT:
                if b.data.shape[0] < 16:
                    continue
                e = self._estimator(b.data.shape[0], b.fs, b.positions)
                d = self._run(e, b.data[None])
                t = np.array([0.5 * (b.meta.time_start + b.meta.time_end)])
                yield from self._emit(out, t, d, b, b.meta.event)
                continue
            if self.nfft is None:
                raise ConfigError(f"stage {self.name!r}: time blocks need key 'nfft' (or read "
                                  "event blocks from a 'transients' stage)")
            if frames is None:
                frames = FrameBuffer(self.nfft, self.hop or self.nfft // 2)
                est = self._estimator(self.nfft, b.fs, b.positions)
            fr, starts = frames.push(b.data[: b.meta.n_valid], b.meta.sample0)
            if fr.shape[0]:
                d = self._run(est, fr)
                t = (starts + 0.5 * self.nfft) / b.fs
                yield from self._emit(out, t, d, b, -1)

    def _sources(self, t: np.ndarray, pk, est: PairPeakEstimator, n_ch: int):
        """The source rows of every snapshot's peaks (:func:`.closure.closure_hypotheses`):
        (time, tau, sigma, corr, source, closure) stacked over snapshots."""
        g = est.gcc
        floor = self.closure_floor if self.closure_floor is not None else 0.2 / g.band_width
        rows = []
        for i in range(t.size):
            h = closure_hypotheses(pk.tau[i], pk.sigma[i], pk.corr[i], pk.pairs, n_ch,
                                   self.reference, self.max_sources or self.peaks,
                                   self.closure_sigmas, floor, self.min_closure)
            H = h.tau.shape[0]
            rows.append((np.full(H, t[i]), h.tau, h.sigma, h.corr, np.arange(H), h.closure))
        return [np.concatenate(c) for c in zip(*rows, strict=True)] if rows else None

    def _emit(self, out, t, d, b: Block, event: int) -> Iterator[Block]:
        if isinstance(d, tuple):  # (peaks, estimator): several sources per snapshot
            yield from self._emit_sources(out, t, d[0], d[1], b, event)
            return
        if out is not None:
            out.append(time=t, tau=d.tau, sigma=d.sigma, corr=d.corr)
        el = self._world(b)
        for i in range(t.size):
            meta = DelaysMeta(float(t[i]), d.sigma[i], d.corr[i], self.reference, el,
                              self.ctx.sound_speed, event)
            yield Block(d.tau[i], DELAYS, float(t[i]), 0.0, b.fs,  # type: ignore[arg-type]
                        b.positions, b.pose, index=b.index, meta=meta)

    def _emit_sources(self, out, t, pk, est, b: Block, event: int) -> Iterator[Block]:
        if self.ctx.products is not None:
            g = self.ctx.products.group(f"{self.name}_peaks", "delay_peaks", self.name,
                                        reference=self.reference, peaks=self.peaks)
            g.set("pairs", pk.pairs)
            g.append(time=t, tau=pk.tau, sigma=pk.sigma, corr=pk.corr, snr_db=pk.snr_db)
        n_ch = pk.pairs.max() + 1 if pk.pairs.size else 1
        tt, tau, sig, corr, src, clo = self._sources(t, pk, est, int(n_ch))
        if out is not None and tt.size:
            out.append(time=tt, tau=tau, sigma=sig, corr=corr, source=src.astype(np.int64),
                       closure=clo)
        el = self._world(b)
        for i in range(tt.size):
            meta = DelaysMeta(float(tt[i]), sig[i], corr[i], self.reference, el,
                              self.ctx.sound_speed, event, int(src[i]))
            yield Block(tau[i], DELAYS, float(tt[i]), 0.0, b.fs,  # type: ignore[arg-type]
                        b.positions, b.pose, index=b.index, meta=meta)
