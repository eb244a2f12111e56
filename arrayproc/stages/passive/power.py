"""``power``: per-channel band power of each time block, and ``pass``: a no-op stage."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from arrayproc.chain import Param, Stage, positive, register
from arrayproc.chain.block import Block
from arrayproc.chain.domains import Domain
from arrayproc.dsp import fft
from arrayproc.dsp.bands import check_nyquist
from arrayproc.io.units import recording_units, reference_amplitude


@register
class Power(Stage):
    """Mean-square pressure per channel in a band, per time block (Parseval on the rfft).

    Writes products group of kind ``power``: ``time`` (block centre, s), ``power_db``
    (n, n_channels) in dB re 1 unit² (dB re 1 µPa² for data in Pa, with ``ref`` = 1e-6).
    Blocks pass through unchanged.
    """

    kind = "power"
    accepts = frozenset({Domain.TIME})
    params = {
        "band": Param("band", None, "frequency band [lo, hi] Hz; whole band when absent",
                      unit="Hz"),
        "ref": Param("float", None, "reference amplitude for dB, in sample units (default: "
                     "1 µPa for data in Pa, full scale for data in FS)",
                     check=positive, unit="sample units"),
    }

    def process(self, blocks: Iterator[Block]) -> Iterator[Block]:
        check_nyquist(self.band, self.fs_in / 2, f"stage {self.name!r}")
        ref = reference_amplitude(recording_units(self.ctx.recording), self.ref)
        out = self.products("power")
        for b in blocks:
            n_valid = b.meta.n_valid
            x = b.data[:n_valid]
            spec = fft.rfft(x, axis=0)
            f = np.fft.rfftfreq(n_valid, 1.0 / b.fs)
            p2 = np.abs(spec) ** 2
            p2[1:] *= 2.0
            if n_valid % 2 == 0:
                p2[-1] /= 2.0
            if self.band is not None:
                p2 = p2[(f >= self.band[0]) & (f <= self.band[1])]
            ms = p2.sum(axis=0) / max(n_valid, 1) ** 2
            if out is not None:
                out.append(time=np.array([b.t0 + 0.5 * n_valid / b.fs]),
                           power_db=(10 * np.log10(np.maximum(ms, 1e-300) / ref**2))[None])
            yield b


@register
class PassThrough(Stage):
    """Passes blocks on unchanged (for measuring the reader and the engine alone)."""

    kind = "pass"
    params = {}

    def process(self, blocks: Iterator[Block]) -> Iterator[Block]:
        yield from blocks
