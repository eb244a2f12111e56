"""``btr``: bearing-time record, the broadband beam power per integrated snapshot.

For each snapshot of the input (power blocks ``("snapshot", "freq", "beam")`` from
``integrate``) the power is summed over the bins in ``band`` (default: every bin of the input):
``P(θ) = Σ_f S_inco(θ, f)`` (thesis eq. 2.22 summed over frequency). Writes products group of
kind ``btr``: ``time`` (n_t) s (centre of the integrated snapshots), ``cone_deg`` (n_beams),
``power_db`` (n_t, n_beams) float32 in dB re ``ref``² (1 µPa² for data in Pa; the CBF sums are
unnormalised, so the level includes the gains N_DFT·N_H·N_B of thesis 2.1.2.1). For 3-D beams
``cone_deg`` holds the relative bearings and ``elevation_deg`` the elevations; for the
relative-bearing beams of ``lr_cbf`` (attr ``beam_mode = "lr"``) ``cone_deg`` holds relative
bearings in (−180°, 180°], port negative. Blocks pass on.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from arrayproc.chain import Param, Stage, positive, register
from arrayproc.chain.block import Block
from arrayproc.chain.domains import Domain
from arrayproc.dsp.bands import band_bins
from arrayproc.io.units import recording_units, reference_amplitude
from arrayproc.stages.passive._common import beam_columns, check_power_block, snapshot_times


@register
class BTR(Stage):
    """Broadband bearing-time record (products ``btr``); see module doc."""

    kind = "btr"
    accepts = frozenset({Domain.POWER})
    params = {
        "band": Param("band", None, "[lo, hi] Hz summed (default: all input bins); "
                      "products btr", unit="Hz"),
        "ref": Param("float", None, "reference amplitude for dB, in sample units (default: "
                     "1 µPa for data in Pa, full scale for data in FS)", check=positive,
                     unit="sample units"),
    }

    def process(self, blocks: Iterator[Block]) -> Iterator[Block]:
        out = None
        idx = None
        for b in blocks:
            check_power_block(self, b)
            if idx is None:
                idx = band_bins(b.freqs, self.band, f"stage {self.name!r}")
                out = self.products("btr")
                if out is not None:
                    for k, v in beam_columns(b.beams).items():
                        out.set(k, v)
                    out.attrs["beam_mode"] = str(getattr(b.meta, "beam_mode", "cone"))
                    out.attrs["freq_lo"] = float(b.freqs[idx[0]])
                    out.attrs["freq_hi"] = float(b.freqs[idx[-1]])
            p = b.data[:, idx[0]:idx[-1] + 1, :] if idx.size == idx[-1] - idx[0] + 1 \
                else b.data[:, idx, :]
            bp = p.sum(axis=1, dtype=np.float64)
            if out is not None:
                ref = reference_amplitude(recording_units(self.ctx.recording), self.ref)
                db = 10 * np.log10(np.maximum(bp, 1e-300) / ref**2)
                out.append(time=snapshot_times(b), power_db=db.astype(np.float32))
            yield b
