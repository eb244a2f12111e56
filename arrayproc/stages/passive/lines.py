"""``lines``: narrowband line contacts, one per (snapshot, line), products ``lines``.

Input: power blocks ``("snapshot", "freq", "beam")`` from ``integrate`` (cone-angle beams).
Per integrated snapshot each beam's spectrum over ``band`` is divided by its TPSW background
(:mod:`arrayproc.dsp.tpsw`, as the ``lofar`` display; ``tpsw_window``, ``tpsw_gap``,
``tpsw_clip``), giving r(b, f) in dB. A tonal shows in every beam at its frequency (main lobe
and sidelobes) and in a few bins (the window's main lobe, Doppler smear), so lines are found
on the best beam per bin, ``R(f) = max_b r(b, f)``:

- a line is a run of consecutive bins with ``R ≥ threshold_db``; a run is split at a valley
  more than 3 dB (half power) below both of its neighbouring maxima, so two tonals a few bins
  apart stay two lines, one tonal over several bins stays one;
- at most ``max_lines`` lines per snapshot, strongest first.

Each line gives one contact at its peak bin f* (the bin of the run with the highest R) and
beam b*, the beam of the largest excess power over the TPSW background, summed over the
line's bins and the window's main lobe, among the beams whose summed power stands
``beam_floor_db`` over their background (:func:`line_beam`). Neither the
ratio nor the level points at the source: a broadband source raises its own beams'
background, so the ratio of a tonal inside its sector peaks off it on a sidelobe, and the
level at f* peaks on the broadband source itself; the excess is the tonal's own beam
pattern. The line is detected on the ratio, so b* may lie where the ratio is under the
threshold (``snr_db`` is the ratio at b*):

- ``cone_deg``: vertex of the parabola through the dB excess of b* and its two neighbours;
  ``bearing_port_deg = heading − cone``, ``bearing_stbd_deg = heading + cone``
  (deg true, the left-right pair; heading of the array at the snapshot); ``beam`` = b*;
- ``freq_hz``: f* + δ·Δf, δ the vertex of the parabola through the dB levels of beam b* at
  f* and its two neighbouring bins, with the frames' taper bias removed
  (:func:`arrayproc.dsp.tone_offset.tone_offset`; the bare parabola is off by up to
  0.016 bin for Hann frames, which a tracker fusing the frequencies reads as a change);
- ``bandwidth_hz``: the half-power width of that spectrum around f*
  (:func:`arrayproc.dsp.peaks.half_power_width`), ≈ 1.44 bins for an unsmeared Hann tone;
- ``snr_db``: r(b*, f*), the line over the TPSW background (10·log10((S + N)/N));
- ``level_db``: the tone's received level at a hydrophone, dB re ``ref``² (1 µPa² for data
  in Pa, full scale for FS): the background-subtracted beam power summed over the line's bins
  and the window's main lobe (±``lobe_bins`` around f*; Parseval makes the sum independent of
  where the tone falls between bins), corrected by the parabola's beam-vertex gain and
  converted by :func:`arrayproc.stages.passive._common.received_level_offset_db`.

False alarms: in noise an integrated bin of N_B snapshots over its background is
Gamma(N_B, 1/N_B) distributed, so a cell exceeds the threshold η (linear) with probability
``Q(N_B, N_B·η)`` (regularised upper incomplete gamma); the expected false contacts per
snapshot are at most n_bins · n_beams · Q (union bound; fewer, as beams are correlated and a
run counts once). Blocks pass on.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from arrayproc.chain import Param, Stage, positive, register
from arrayproc.chain.block import Block
from arrayproc.chain.domains import Domain
from arrayproc.dsp.bands import band_bins
from arrayproc.dsp.peaks import half_power_width, parabolic_vertex
from arrayproc.dsp.tone_offset import tone_offset
from arrayproc.dsp.tpsw import tpsw, tpsw_db
from arrayproc.errors import ConfigError
from arrayproc.io.units import recording_units, reference_amplitude
from arrayproc.stages.passive._common import (
    check_power_block,
    received_level_offset_db,
    snapshot_times,
)

COLUMNS = ("time", "cone_deg", "bearing_port_deg", "bearing_stbd_deg", "freq_hz",
           "bandwidth_hz", "level_db", "snr_db", "beam")
#: a valley this far below both neighbouring maxima splits a run into two lines (half power)
SPLIT_DB = 3.0103


def line_runs(best_db: np.ndarray, threshold_db: float) -> list[tuple[int, int, int]]:
    """Lines of a best-beam spectrum ``best_db`` (n,): runs of bins at or above
    ``threshold_db``, split at valleys :data:`SPLIT_DB` below both neighbouring maxima.
    Returns ``[(first_bin, last_bin, peak_bin), ...]`` in frequency order."""
    above = np.r_[False, best_db >= threshold_db, False]
    edges = np.flatnonzero(np.diff(above.astype(np.int8)))
    out: list[tuple[int, int, int]] = []
    for a, e in zip(edges[::2], edges[1::2]):
        seg = best_db[a:e]
        left = np.r_[-np.inf, seg[:-1]]
        right = np.r_[seg[1:], -np.inf]
        peaks = np.flatnonzero((seg > left) & (seg >= right))
        lo, top = 0, int(peaks[0])
        for p, q in zip(peaks[:-1], peaks[1:]):
            v = int(p + np.argmin(seg[p:q + 1]))
            if seg[v] < min(seg[top], seg[q]) - SPLIT_DB:
                out.append((a + lo, a + v, a + top))
                lo, top = v + 1, int(q)
            elif seg[q] > seg[top]:
                top = int(q)
        out.append((a + lo, e - 1, a + top))
    return out


def line_beam(power: np.ndarray, background: np.ndarray, cone: np.ndarray, floor_db: float
              ) -> tuple[int, float, float, float]:
    """The beam of a line: its peak beam, cone angle, vertex gain (dB) and excess power.

    ``power`` and ``background`` (B, n) are each beam's power and TPSW background in the
    line's bins and the window's main lobe around them. Summed over the bins (Parseval:
    independent of where the tone falls between bins), the excess ``power − background`` is
    the tonal's own beam pattern with the broadband of every beam (a tow ship's sector)
    removed, but its noise grows with the background: in a beam 20 dB louder than the
    tonal's, its fluctuations exceed the tonal. So the peak beam b* is the beam of the
    largest excess among the beams whose summed power stands at least ``floor_db`` over
    their background (the most significant beam when none does), and the cone the vertex of
    the parabola through the dB excess of b* and its two neighbours (where both are
    positive), with the vertex's gain over b*.
    """
    p, q = power.sum(axis=1), background.sum(axis=1)
    e = p - q
    ok = p >= q * 10 ** (floor_db / 10)
    bi = int(np.argmax(np.where(ok, e, -np.inf))) if ok.any() else int(np.argmax(p / q))
    c, gain = float(cone[bi]), 0.0
    if 0 < bi < e.size - 1 and e[bi - 1] > 0 and e[bi + 1] > 0 and e[bi] > 0:
        row = 10 * np.log10(e[bi - 1:bi + 2])
        c, top = parabolic_vertex(cone[bi - 1:bi + 2], row)
        gain = top - row[1]
    return bi, c, gain, float(e[bi])


@register
class Lines(Stage):
    """Narrowband line contacts (products ``lines``); see module doc."""

    kind = "lines"
    accepts = frozenset({Domain.POWER})
    params = {
        "band": Param("band", None, "[lo, hi] Hz searched for lines (default: all input bins)"),
        "threshold_db": Param("float", 12.0, "line threshold over the TPSW background, dB",
                              check=positive),
        "beam_floor_db": Param("float", 3.0, "a beam may be a line's when its power over the "
                               "line's bins stands this far over its background, dB",
                               check=positive),
        "max_lines": Param("int", 16, "lines per snapshot (strongest first)", check=positive),
        "lobe_bins": Param("int", 2, "half-width of the window's main lobe summed for the "
                           "level, bins (2 for Hann)",
                           check=lambda v: None if v >= 0 else "must be >= 0"),
        "tpsw_window": Param("int", 32, "TPSW half-window, bins", check=positive),
        "tpsw_gap": Param("int", 3, "TPSW half-gap, bins"),
        "tpsw_clip": Param("float", 2.0, "TPSW clipping ratio", check=positive),
        "ref": Param("float", None, "reference amplitude for dB, in sample units (default: "
                     "1 µPa for data in Pa, full scale for data in FS)", check=positive),
    }

    def validate(self) -> None:
        if not 0 <= self.tpsw_gap < self.tpsw_window:
            raise ConfigError(f"stage {self.name!r}: key 'tpsw_gap' must be in [0, "
                              f"tpsw_window), got {self.tpsw_gap}")

    def process(self, blocks: Iterator[Block]) -> Iterator[Block]:
        out = None
        idx = None
        for b in blocks:
            check_power_block(self, b)
            cone = np.asarray(b.beams, float)
            if cone.ndim != 1 or getattr(b.meta, "beam_mode", "cone") == "lr":
                raise ConfigError(f"stage {self.name!r}: needs cone-angle beams "
                                  "(beams = {start, stop, count})")
            if idx is None:
                idx = band_bins(b.freqs, self.band, f"stage {self.name!r}")
                out = self.products("lines")
            times = snapshot_times(b)
            heads = np.asarray(b.meta.headings, float)
            lref = 10 * np.log10(reference_amplitude(recording_units(self.ctx.recording),
                                                     self.ref) ** 2)
            off = received_level_offset_db(b, broadband=True) + lref
            freqs = np.asarray(b.freqs, float)[idx]
            taper = (str(b.meta.window), int(b.meta.nfft))
            rows: dict[str, list] = {k: [] for k in COLUMNS}
            for s in range(b.data.shape[0]):
                spec = np.ascontiguousarray(b.data[s][idx].T, dtype=np.float64)  # (B, F)
                self._contacts(spec, freqs, cone, float(times[s]), float(heads[s]), off, rows,
                               taper)
            if out is not None and rows["time"]:
                cols = {k: np.asarray(v, float) for k, v in rows.items()}
                cols["beam"] = cols["beam"].astype(np.int64)
                out.append(**cols)
            yield b

    def _contacts(self, spec: np.ndarray, freqs: np.ndarray, cone: np.ndarray, t: float,
                  heading: float, off_db: float, rows: dict[str, list],
                  taper: tuple[str, int]) -> None:
        """Contacts of one snapshot's beam spectra ``spec`` (B, F) into ``rows``."""
        bg = tpsw(spec, self.tpsw_window, self.tpsw_gap, self.tpsw_clip)
        r_db = tpsw_db(spec, bg)
        runs = line_runs(r_db.max(axis=0), self.threshold_db)
        runs = sorted(runs, key=lambda r: -r_db[:, r[2]].max())[: self.max_lines]
        n_b, n_f = spec.shape
        for lo, hi, fi in sorted(runs, key=lambda r: r[2]):
            a, e = max(0, min(lo, fi - self.lobe_bins)), min(n_f, max(hi, fi + self.lobe_bins) + 1)
            bi, c, gain, excess = line_beam(spec[:, a:e], bg[:, a:e], cone,
                                            self.beam_floor_db)
            sp = 10 * np.log10(np.maximum(spec[bi], 1e-300))
            f = float(freqs[fi])
            if 0 < fi < n_f - 1:
                f += tone_offset(sp[fi - 1:fi + 2], *taper) * float(freqs[fi + 1] - freqs[fi])
            rows["time"].append(t)
            rows["cone_deg"].append(c)
            rows["bearing_port_deg"].append((heading - c) % 360.0)
            rows["bearing_stbd_deg"].append((heading + c) % 360.0)
            rows["freq_hz"].append(f)
            rows["bandwidth_hz"].append(half_power_width(sp, freqs, fi))
            rows["level_db"].append(10 * np.log10(max(excess, 1e-300)) + gain - off_db)
            rows["snr_db"].append(float(r_db[bi, fi]))
            rows["beam"].append(bi)
