"""``matched_filter``: the wideband Doppler matched-filter bank of thesis eqs. (4.7)-(4.8) on
each ping's beams (:mod:`arrayproc.stages.active.bank`), streamed in beam chunks.

Input: ``active_beams`` blocks (one per ping). Output: blocks of domain ``RANGE_DOPPLER``
(beam x range_rate x range) holding |chi|^2 (float32) of ``chunk`` beams x D range-rate
channels x the ping's lags, with the ping's :class:`arrayproc.chain.domains.PingMeta`; its
``extra``: ``kind`` (waveform kind), ``range_rates`` (D,) m/s, ``lag0`` (lag index of column
0), ``fs_bb``, ``bandwidth``, ``duration`` (pulse length T, s), ``beam_index`` (indices into
the ping's beams), ``cones`` (deg), ``last`` (the ping's final block) and ``cells`` (cells
computed in the block). A ping's cube (e.g. 271 channels x 181 beams x 35 000 lags) is
never held: one block at a time, of at most ``chunk`` beams and ``block_mb`` MB (at 271
channels x 32 580 lags one beam's plane is 35 MB, so two beams per block).

The replicas come from the recording (``/active/waveforms``), so one chain serves any
waveform; a Doppler-insensitive one (HFM, LFM) gets the single channel 0 m/s.

Bracket mode (thesis 4.2.3): with ``bracket = {source = "<cfar stage>", range_m = R,
cone_deg = A}``, a Doppler-sensitive ping is filtered only around the contacts that the named
``cfar`` stage found on the most recent earlier Doppler-insensitive (HFM) ping: beams within
+-A deg of each contact's cone angle, lags of the ranges within +-R m. Each bracket is
correlated on its own data segment by an FFT just longer than segment + pulse, with the
replica spectra evaluated at that FFT's bins. Doppler-insensitive pings yield nothing in this
mode (their contacts come from the source stage). ``cells`` counts the cells computed.

Optional ``range_doppler = {pings = [...], cones = [...], range_m = [lo, hi]}`` writes the
``range_doppler`` product (docs/formats.md) of the beams nearest to ``cones`` on those pings,
for the display.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import scipy.fft as sfft

from arrayproc.chain import Block, Param, Stage, positive, register
from arrayproc.chain.domains import Domain, PingMeta
from arrayproc.errors import ConfigError

from . import _common as cm
from .bank import Correlator, doppler_scale, range_rate_grid, replica_spectra
from .contacts import bistatic_path


@register
class MatchedFilter(Stage):
    """Doppler matched-filter bank per ping and beam (see module doc)."""

    kind = "matched_filter"
    accepts = frozenset({Domain.BEAM_TIME})
    produces = Domain.RANGE_DOPPLER
    params = {
        "range_rate": Param("table", {}, "range-rate channels {min, max, step}, m/s (default "
                            "+-15 m/s at the waveform's 3 dB Doppler resolution)", unit="m/s"),
        "chunk": Param("int", 8, "beams per output block at most", check=positive),
        "block_mb": Param("float", 96.0, "largest output block, MB: fewer beams per block "
                          "when chunk beams would exceed it (at least one per thread)",
                          unit="MB"),
        "max_range_m": Param("float", 0.0, "longest range kept, m (0: the whole window)", unit="m"),
        "bracket": Param("table", None, "{source, range_m, cone_deg}: bracket mode"),
        "range_doppler": Param("table", None, "{pings, cones, range_m}: write range_doppler"),
        "threads": Param("int", 0, "FFT threads (0: all cores)"),
    }

    def validate(self) -> None:
        w = f"stage {self.name!r}"
        try:  # keys and signs now; the step default needs the waveform, known at run time
            range_rate_grid(self.range_rate, 1000.0, 1.0, 1500.0, False)
        except ConfigError as e:
            raise ConfigError(f"{w}: {e}") from None
        if not self.block_mb > 0:
            raise ConfigError(f"{w}: key 'block_mb' must be > 0 MB, got {self.block_mb}")
        if self.bracket is not None:
            b = dict(self.bracket)
            if set(b) - {"source", "range_m", "cone_deg"} or not isinstance(b.get("source"),
                                                                               str):
                raise ConfigError(f"{w}: key 'bracket' must be {{source = \"<cfar stage>\", "
                                  "range_m = ..., cone_deg = ...}")
            try:
                self._br = (b["source"], float(b.get("range_m", 200.0)),
                            float(b.get("cone_deg", 5.0)))
            except (TypeError, ValueError):
                raise ConfigError(f"{w}: key 'bracket': range_m and cone_deg must be "
                                  "numbers") from None
            if self._br[1] <= 0 or self._br[2] < 0:
                raise ConfigError(f"{w}: key 'bracket': range_m > 0 and cone_deg >= 0")
        if self.range_doppler is not None:
            rd = dict(self.range_doppler)
            try:
                self._rd = ({int(p) for p in rd.get("pings", [])},
                            [float(x) for x in rd.get("cones", [])],
                            [float(x) for x in rd.get("range_m", [0.0, 2000.0])])
            except (TypeError, ValueError):
                raise ConfigError(f"{w}: key 'range_doppler' must be {{pings = [ints], cones = "
                                  "[deg], range_m = [lo, hi]}") from None
        self._banks: dict = {}

    def _workers(self) -> int:
        return self.threads if self.threads > 0 else (os.cpu_count() or 1)

    def _correlator(self, d: int, k: int) -> Correlator:
        """This thread's Correlator for a (D, K) bank (each worker owns its FFT plan)."""
        tl = self.__dict__.setdefault("_tl", threading.local())
        cache = getattr(tl, "c", None)
        if cache is None:
            cache = tl.c = {}
        if (d, k) not in cache:
            if len(cache) > 4:
                cache.clear()
            cache[(d, k)] = Correlator(d, k)
        return cache[(d, k)]

    def _map(self, fn, items: list) -> list:
        if self._workers() <= 1 or len(items) <= 1:
            return [fn(i) for i in items]
        pool = self.__dict__.get("_pool")
        if pool is None:
            pool = self._pool = ThreadPoolExecutor(self._workers())
        return list(pool.map(fn, items))

    def _bank(self, name: str, wf, f0: float, df: float, n: int) -> tuple[np.ndarray,
                                                                           np.ndarray]:
        key = (name, round(f0, 9), round(df, 12), n)
        if key not in self._banks:
            if len(self._banks) > 8:
                self._banks.clear()
            c = self.ctx.sound_speed
            try:
                rr = range_rate_grid(self.range_rate, wf.fc, wf.duration, c,
                                     cm.insensitive(wf.kind))
            except ConfigError as e:
                raise ConfigError(f"stage {self.name!r}: {e}") from None
            bank = replica_spectra(wf.samples, wf.fs, f0, df, n, doppler_scale(rr, c),
                                   map_fn=lambda f, items: self._map(f, list(items)))
            self._banks[key] = (rr, bank)
        return self._banks[key]

    def process(self, blocks: Iterator[Block]) -> Iterator[Block]:
        act = None
        for b in blocks:
            if act is None:
                act = cm.schedule(self.ctx.recording, f"stage {self.name!r}")
            wf = act.waveforms[b.meta.waveform]
            if self.bracket is not None:
                yield from self._bracketed(b, wf)
            else:
                yield from self._full(b, wf)

    def _meta(self, b: Block, wf, rr: np.ndarray, **kw) -> PingMeta:
        m = b.meta
        extra = {"kind": wf.kind, "range_rates": rr, "fs_bb": b.fs, "bandwidth": wf.bandwidth,
                 "duration": wf.duration}
        extra.update(kw)
        return PingMeta(m.ping, m.waveform, m.t_ping, m.fc, m.speed, m.heading, m.projector,
                        extra)

    def _n_lags(self, b: Block) -> int:
        n = int(b.meta.extra["n_lags"])
        if self.max_range_m > 0:
            n = min(n, int(np.ceil(2.2 * self.max_range_m / self.ctx.sound_speed * b.fs)))
        return n

    def _full(self, b: Block, wf) -> Iterator[Block]:
        plan = b.meta.extra["plan"]
        rr, bank = self._bank(b.meta.waveform, wf, plan.f0, plan.df, plan.n_bins)
        data = b.data.T  # (B, K), beam-major
        nb, k = data.shape
        nl = self._n_lags(b)
        w = self._workers()
        per = self._per_block(rr.size * nl * 4, w)
        for a in range(0, nb, per):
            idx = np.arange(a, min(nb, a + per))
            spec = sfft.fft(data[idx], axis=1, workers=w).astype(np.complex64)
            out = np.empty((idx.size, rr.size, nl), np.float32)

            def one(j: int, spec=spec, out=out) -> None:
                self._correlator(rr.size, k)(spec[j], bank, out[j], 0)

            self._map(one, list(range(idx.size)))
            cones = np.asarray(b.beams)[idx]
            self._write_rd(b, rr, out, idx, cones, 0)
            yield Block(out, Domain.RANGE_DOPPLER, b.t0, b.span, b.fs, b.positions,
                        pose=b.pose, beams=cones, index=b.index,
                        meta=self._meta(b, wf, rr, lag0=0, beam_index=idx, cones=cones,
                                        last=idx[-1] == nb - 1, cells=out.size))
            del out, spec, one  # this block's memory goes before the next one is made

    def _per_block(self, beam_bytes: int, workers: int) -> int:
        """Beams per output block: ``chunk``, fewer when that many beam planes of
        ``beam_bytes`` would exceed ``block_mb`` (never fewer than the worker threads)."""
        fit = int(self.block_mb * 1e6 // max(beam_bytes, 1))
        return max(1, min(self.chunk, max(fit, workers)))

    def _write_rd(self, b: Block, rr: np.ndarray, out: np.ndarray, idx: np.ndarray,
                  cones: np.ndarray, lag0: int) -> None:
        if self.range_doppler is None or b.meta.ping not in self._rd[0]:
            return
        w = self.products("range_doppler")
        if w is None:
            return
        axis = np.asarray(b.beams, float).reshape(len(b.beams), -1)[:, 0]
        c = self.ctx.sound_speed
        lo, hi = self._rd[2]
        for cone in self._rd[1]:
            bi = int(np.argmin(np.abs(axis - cone)))
            hit = np.flatnonzero(idx == bi)
            if hit.size == 0:
                continue
            proj = b.meta.projector
            l0 = int(np.floor(bistatic_path(lo, axis[bi], proj, b.meta.speed, c) / c * b.fs))
            l0 -= lag0
            nl = int(np.ceil(2 * (hi - lo) / c * b.fs))
            if l0 < 0 or l0 + nl > out.shape[2]:
                continue
            lags = (lag0 + l0 + np.arange(nl)) / b.fs
            from .contacts import bistatic_range
            rng = bistatic_range(lags * c, axis[bi], proj, b.meta.speed, c)
            lev = 10 * np.log10(np.maximum(out[hit[0], :, l0:l0 + nl], 1e-30))
            w.append(time=np.array([b.t0]), ping=np.array([b.meta.ping]),
                     cone_deg=np.array([axis[bi]]), range_m=rng[None],
                     range_rate_mps=rr[None], level_db=lev[None].astype(np.float32))

    def _bracketed(self, b: Block, wf) -> Iterator[Block]:
        if cm.insensitive(wf.kind):
            return
        src, rgate, cgate = self._br
        prev = cm.previous_insensitive(self.ctx, src, int(b.meta.ping))
        data = b.data.T
        nb, k = data.shape
        fs_bb = b.fs
        c = self.ctx.sound_speed
        plan = b.meta.extra["plan"]
        rr = range_rate_grid(self.range_rate, wf.fc, wf.duration, c, False)
        n_rep = int(np.ceil(wf.duration / float(doppler_scale(rr.max(), c)) * fs_bb)) + 8
        nl_all = self._n_lags(b)
        axis = np.asarray(b.beams, float).reshape(nb, -1)[:, 0]
        segs: dict[int, list[tuple[int, int]]] = {}
        if prev is not None:
            con = prev[1]
            for r, cone in zip(con["range_m"], con["cone_deg"]):
                beams = np.flatnonzero(np.abs(axis - cone) <= cgate + 1e-9)
                if beams.size == 0:
                    beams = np.array([int(np.argmin(np.abs(axis - cone)))])
                for bi in beams:
                    a = bistatic_path(max(r - rgate, 0.0), axis[bi], b.meta.projector,
                                      b.meta.speed, c)
                    e = bistatic_path(r + rgate, axis[bi], b.meta.projector, b.meta.speed, c)
                    l0 = max(0, int(np.floor(a / c * fs_bb)))
                    l1 = min(nl_all, int(np.ceil(e / c * fs_bb)) + 1)
                    if l1 > l0:
                        segs.setdefault(int(bi), []).append((l0, l1))
        blocks = []
        for bi in sorted(segs):
            iv = sorted(segs[bi])
            merged = [list(iv[0])]
            for l0, l1 in iv[1:]:
                if l0 <= merged[-1][1]:
                    merged[-1][1] = max(merged[-1][1], l1)
                else:
                    merged.append([l0, l1])
            for l0, l1 in merged:
                blocks.append((bi, l0, l1))
        if not blocks:
            yield Block(np.zeros((0, rr.size, 0), np.float32), Domain.RANGE_DOPPLER, b.t0,
                        b.span, fs_bb, b.positions, pose=b.pose, beams=axis[:0], index=b.index,
                        meta=self._meta(b, wf, rr, lag0=0, beam_index=np.zeros(0, np.int64),
                                        cones=axis[:0], last=True, cells=0))
            return
        w = self._workers()
        for j, (bi, l0, l1) in enumerate(blocks):
            nseg = sfft.next_fast_len(l1 - l0 + n_rep)
            seg = np.zeros(nseg, np.complex64)
            take = data[bi, l0:min(k, l0 + nseg)]
            seg[:take.size] = take
            # bins of the segment's FFT: baseband offsets j fs_bb / nseg above f0
            _, bank = self._bank(b.meta.waveform, wf, plan.f0, fs_bb / nseg, nseg)
            spec = sfft.fft(seg, workers=w).astype(np.complex64)
            out = np.empty((1, rr.size, l1 - l0), np.float32)
            self._correlator(rr.size, nseg)(spec, bank, out[0], 0)
            yield Block(out, Domain.RANGE_DOPPLER, b.t0, b.span, fs_bb, b.positions,
                        pose=b.pose, beams=axis[[bi]], index=b.index,
                        meta=self._meta(b, wf, rr, lag0=l0, beam_index=np.array([bi]),
                                        cones=axis[[bi]], last=j == len(blocks) - 1,
                                        cells=out.size))
