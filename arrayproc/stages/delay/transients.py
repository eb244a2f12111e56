"""``transients``: transient sounds on a reference channel → ``detections`` and event blocks.

Detection by band energy over a running-median background (:mod:`.detect`). For every
detection the stage writes a ``detections`` row (``time_start``, ``time_end``, ``freq_lo``,
``freq_hi``, ``snr_db``, ``channel``; docs/formats.md) and yields an event block: the samples
of every channel over the detection's time box padded on each side by ``pad`` (default: the
array's largest travel time between two elements plus one detection frame), clipped to the
recording, so events at the start or end of a file still work. Memory is bounded by the
background window, ``max_duration`` and the padding, not by the file length.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from arrayproc.chain import Param, Stage, positive, register
from arrayproc.chain.block import Block
from arrayproc.chain.domains import Domain, EventMeta
from arrayproc.errors import ConfigError

from .detect import TransientDetector


@register
class Transients(Stage):
    """Transient detection on ``channel`` (see the module docstring)."""

    kind = "transients"
    accepts = frozenset({Domain.TIME})
    produces = Domain.EVENT
    params = {
        "channel": Param("int", 0, "reference channel of the detection"),
        "band": Param("band", None, "band [lo, hi] Hz of the energy (default: 0 to fs/2)",
                      unit="Hz"),
        "threshold_db": Param("float", 10.0, "threshold over the running-median background, dB",
                              unit="dB"),
        "min_duration": Param("float", 0.02, "shortest event, s", unit="s"),
        "merge_gap": Param("float", 0.05, "events closer than this merge, s", check=positive,
                           unit="s"),
        "max_duration": Param("float", 2.0, "longer events are cut, s", check=positive, unit="s"),
        "nfft": Param("int", 512, "detection frame length, samples (hop nfft/2)",
                      check=lambda v: None if v >= 8 else "must be >= 8", unit="samples"),
        "background": Param("float", 5.0, "median background window, s", check=positive, unit="s"),
        "pad": Param("float", None, "padding of event blocks, s (default: largest travel "
                     "time across the array plus one frame)", unit="s"),
    }

    def warmup_seconds(self, fs: float) -> float:
        """A segment needs the background window's half, the longest event and its padding
        before its start to detect as one long run does."""
        pad = self.pad if self.pad is not None else 0.01 + self.nfft / fs
        return self.background / 2 + self.max_duration + self.merge_gap + pad

    def process(self, blocks: Iterator[Block]) -> Iterator[Block]:
        out = self.products("detections")
        det = None
        buf = None
        buf0 = 0
        pending: list = []
        n_ev = 0
        last = None
        for b in blocks:
            if det is None:
                n_ch = b.data.shape[1]
                if not 0 <= self.channel < n_ch:
                    raise ConfigError(f"stage {self.name!r}: key 'channel': {self.channel} "
                                      f"outside 0..{n_ch - 1}")
                band = self.band or (0.0, b.fs / 2)
                det = TransientDetector(b.fs, band, self.threshold_db, self.min_duration,
                                        self.merge_gap, self.max_duration, self.nfft,
                                        self.background)
                p = np.asarray(b.positions, float)
                span = max(float(np.max(np.linalg.norm(p[:, None] - p[None], axis=-1))), 0.0)
                pad = self.pad if self.pad is not None else (
                    span / self.ctx.sound_speed + self.nfft / b.fs)
                pad_n = int(np.ceil(pad * b.fs))
                keep_n = pad_n + int((self.background / 2 + self.max_duration
                                      + 2 * self.merge_gap) * b.fs) + 2 * self.nfft
                buf = np.zeros((0, n_ch), b.data.dtype)
                buf0 = int(b.meta.sample0)
            x = b.data[: b.meta.n_valid]
            buf = np.concatenate([buf, x])
            pending += det.push(x[:, self.channel])
            ready, pending = self._ready(pending, buf0 + buf.shape[0], b.fs, pad_n)
            for ev in ready:
                yield self._event(ev, buf, buf0, b, pad_n, n_ev, out)
                n_ev += 1
            last = b
            if buf.shape[0] > keep_n:
                drop = buf.shape[0] - keep_n
                buf = buf[drop:]
                buf0 += drop
        if det is None:
            return
        pending += det.push(np.zeros(0), final=True)
        for ev in pending:
            yield self._event(ev, buf, buf0, last, pad_n, n_ev, out)
            n_ev += 1

    @staticmethod
    def _ready(pending, end_sample, fs, pad_n):
        ready = [e for e in pending if int(np.ceil(e.time_end * fs)) + pad_n <= end_sample]
        return ready, [e for e in pending if e not in ready]

    def _event(self, ev, buf, buf0, b, pad_n, n_ev, out) -> Block:
        """The event block of ``ev``, with the positions and pose of block ``b`` (the block
        whose arrival completed the event)."""
        fs = b.fs
        s0 = max(buf0, int(np.floor(ev.time_start * fs)) - pad_n)
        s1 = min(buf0 + buf.shape[0], int(np.ceil(ev.time_end * fs)) + pad_n)
        data = np.ascontiguousarray(buf[s0 - buf0: s1 - buf0])
        if out is not None:
            out.append(time_start=np.array([ev.time_start]), time_end=np.array([ev.time_end]),
                       freq_lo=np.array([ev.freq_lo]), freq_hi=np.array([ev.freq_hi]),
                       snr_db=np.array([ev.snr_db]), channel=np.array([self.channel]))
        meta = EventMeta(n_ev, s0, ev.time_start, ev.time_end, ev.freq_lo, ev.freq_hi,
                         ev.snr_db, self.channel)
        return Block(data, Domain.EVENT, s0 / fs, data.shape[0] / fs, fs, b.positions,
                     b.pose, index=n_ev, meta=meta)
