"""``lofar``: per-beam power spectra over time (LOFAR-gram), products ``lofar``.

Input: power blocks ``("snapshot", "freq", "beam")`` from ``integrate``. For each snapshot and
each selected beam (``beams = "all"`` or a list of cone angles in degrees, each mapped to the
nearest beam) the spectrum over ``band`` (default all input bins) is written. ``normalise =
"tpsw"`` divides each spectrum by its two-pass split-window background
(:mod:`arrayproc.dsp.tpsw`; ``tpsw_window`` half-width and ``tpsw_gap`` in bins,
``tpsw_clip`` ratio), so ``power_db`` is the level over the local background (dB); ``"none"``
writes dB re ``ref``². Datasets: ``time`` (n_t) s, ``freq`` (n_f) Hz, ``cone_deg`` (n_b),
``power_db`` (n_t, n_b, n_f) float32. Blocks pass on.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from arrayproc.chain import Param, Stage, positive, register
from arrayproc.chain.block import Block
from arrayproc.chain.domains import Domain
from arrayproc.dsp.bands import band_bins
from arrayproc.dsp.tpsw import tpsw, tpsw_db
from arrayproc.errors import ConfigError
from arrayproc.io.units import recording_units, reference_amplitude
from arrayproc.stages.passive._common import beam_columns, check_power_block, snapshot_times


def _beams_check(v) -> str | None:
    if v == "all":
        return None
    if isinstance(v, (list, tuple)) and v and all(
            isinstance(x, (int, float)) and not isinstance(x, bool) for x in v):
        return None
    return "must be \"all\" or a non-empty list of cone angles (deg)"


def select_beams(axis: np.ndarray, beams) -> np.ndarray:
    """Indices of the beams nearest the requested cone angles (or all)."""
    if isinstance(beams, str):
        return np.arange(len(axis))
    a = np.asarray(axis, float)
    a = a if a.ndim == 1 else a[:, 0]
    return np.array([int(np.argmin(np.abs(a - float(c)))) for c in beams])


@register
class LOFAR(Stage):
    """Per-beam LOFAR-gram (products ``lofar``); see module doc."""

    kind = "lofar"
    accepts = frozenset({Domain.POWER})
    params = {
        "beams": Param("any", "all", "\"all\" or a list of cone angles (the nearest "
                       "beams), deg; products lofar",
                       check=_beams_check, unit="deg"),
        "band": Param("band", None, "[lo, hi] Hz shown (default: all input bins)", unit="Hz"),
        "normalise": Param("str", "tpsw", "background normalisation: tpsw (level over the "
                           "two-pass split-window background, dB) or none (dB re ref²)",
                           choices=("tpsw", "none")),
        "tpsw_window": Param("int", 32, "TPSW half-window, bins", check=positive, unit="bins"),
        "tpsw_gap": Param("int", 3, "TPSW half-gap, bins", unit="bins"),
        "tpsw_clip": Param("float", 2.0, "TPSW clipping ratio", check=positive),
        "ref": Param("float", None, "reference amplitude for dB (normalise = none), in sample "
                     "units (default: 1 µPa for data in Pa, full scale for data in FS)",
                     check=positive, unit="sample units"),
    }

    def validate(self) -> None:
        if not 0 <= self.tpsw_gap < self.tpsw_window:
            raise ConfigError(f"stage {self.name!r}: key 'tpsw_gap' must be in [0, "
                              f"tpsw_window), got {self.tpsw_gap}")

    def process(self, blocks: Iterator[Block]) -> Iterator[Block]:
        out = None
        fidx = bidx = None
        for b in blocks:
            check_power_block(self, b)
            if fidx is None:
                fidx = band_bins(b.freqs, self.band, f"stage {self.name!r}")
                bidx = select_beams(b.beams, self.beams)
                out = self.products("lofar")
                if out is not None:
                    out.set("freq", b.freqs[fidx])
                    cols = beam_columns(np.asarray(b.beams)[bidx])
                    for k, v in cols.items():
                        out.set(k, v)
                    out.attrs["normalise"] = self.normalise
            p = b.data[:, fidx][:, :, bidx].transpose(0, 2, 1)  # (S, n_b, n_f)
            if out is not None:
                if self.normalise == "tpsw":
                    bg = tpsw(p, self.tpsw_window, self.tpsw_gap, self.tpsw_clip)
                    db = tpsw_db(p, bg)
                else:
                    ref = reference_amplitude(recording_units(self.ctx.recording), self.ref)
                    db = 10 * np.log10(np.maximum(p, 1e-300) / ref**2)
                out.append(time=snapshot_times(b), power_db=db.astype(np.float32))
            yield b
