"""``bearings``: bearing extraction by peak picking on the BTR and on LOFAR lines.

Input: power blocks ``("snapshot", "freq", "beam")`` from ``integrate`` (cone-angle beams).
Per integrated snapshot:

- broadband (``broadband = true``): the beam power summed over ``band`` (a BTR row); its
  robust noise level is the median over beams; every local maximum ``threshold_db`` or more
  above it is a detection, strongest first, at least ``min_separation`` deg from a stronger
  one, at most ``max_peaks``.
- narrowband (``lines = true``): each beam's spectrum is divided by its TPSW background
  (as in ``lofar``); a line is a frequency bin whose best beam stands ``line_threshold_db``
  over the background and is a local maximum in frequency; at each line the beam row is
  peak-picked like the BTR (noise = its median over beams), ignoring peaks more than
  ``line_dynamic_db`` below the strongest one (the sidelobes of a line source: −13.3 dB for
  an unshaded line array).

Peaks are separated by ``min_separation`` deg and, with ``peak_widths`` > 0, by that many
half-power widths of the stronger peak measured on the row itself, so the separation follows
the beam actually produced (the narrow peaks of ``mvdr`` and ``music``, the wide ones of
``cbf``); for adaptive beams use ``min_separation = 0`` and ``peak_widths = 1`` (a warning
says when a fixed separation exceeds twice the measured width of the strongest peak, which can
hide resolved sources). The thresholds are relative to the median over beams, so they hold for
any beam pattern (for ``music`` the levels are pseudo-spectrum values, not sound levels).

Relative-bearing beams from ``lr_cbf`` (beam mode ``"lr"``, axis (−180°, 180°], port
negative): a peak at relative bearing β whose level stands ``lr_rejection_db`` or more above
the level at −β (its mirror) is resolved: ``bearing_port_deg`` and ``bearing_stbd_deg`` both
hold the one true bearing heading + β (so the trackers' left-right hypotheses coincide and no
mirror track forms), ``side`` is +1 (starboard) or −1 (port); below that rejection the row
keeps the ambiguous pair heading ∓ |β| with ``side`` 0. ``cone_deg`` is |β| and
``rel_bearing_deg`` is β (both columns optional in the schema, written for these beams only).

Azimuth × elevation beams from ``cbf_azel`` (beam mode ``"azel"``): 2-D peaks with
``azimuth_deg``, ``elevation_deg`` and ``sigma_deg`` (:mod:`bearings_azel`).

Peaks are refined to sub-beam resolution by a parabola through the peak beam and its two
neighbours (dB against cone angle). Rows (products ``bearings``, docs/formats.md): ``time``
(s), ``cone_deg``, ``bearing_port_deg = heading − cone`` and ``bearing_stbd_deg = heading +
cone`` (deg true, the left-right pair; heading of the array at the snapshot), ``level_db`` (dB
re ``ref``², the thesis's unnormalised beam-power sums), ``snr_db`` (over the noise estimate),
``freq_lo``/``freq_hi`` (Hz: the band summed, or the line's bin edges), ``spl_db`` (the
received level at a hydrophone of a plane wave from the peak's direction: the in-band mean
square for broadband peaks, the tone's mean square for lines; dB re ``ref``², see
:func:`received_level_offset_db`; noise in the beam adds to it at low SNR). Blocks pass on.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterator

import numpy as np

from arrayproc.chain import Param, Stage, positive, register
from arrayproc.chain.block import Block
from arrayproc.chain.domains import Domain
from arrayproc.dsp.bands import band_bins
from arrayproc.dsp.peaks import half_power_width, pick_peaks
from arrayproc.dsp.tpsw import tpsw, tpsw_db
from arrayproc.errors import ConfigError
from arrayproc.io.units import recording_units, reference_amplitude
from arrayproc.stages.passive._common import (
    check_power_block,
    received_level_offset_db,
    snapshot_times,
)
from arrayproc.stages.passive.bearings_azel import AZEL_COLUMNS, azel_rows, grid_axes

COLUMNS = ("time", "cone_deg", "bearing_port_deg", "bearing_stbd_deg", "level_db", "snr_db",
           "freq_lo", "freq_hi", "spl_db")


@register
class Bearings(Stage):
    """Peak picking on BTR rows and LOFAR lines (products ``bearings``); see module doc."""

    kind = "bearings"
    accepts = frozenset({Domain.POWER})
    params = {
        "band": Param("band", None, "[lo, hi] Hz for broadband peaks (default: all bins)",
                      unit="Hz"),
        "broadband": Param("bool", True, "pick peaks on the broadband (BTR) beam power"),
        "lines": Param("bool", False, "pick peaks on narrowband (LOFAR) lines"),
        "threshold_db": Param("float", 6.0, "broadband peak threshold over the median over "
                              "beams, dB",
                              unit="dB"),
        "line_threshold_db": Param("float", 10.0, "line threshold over the TPSW background (and "
                                   "over the beam row's median), dB",
                                   unit="dB"),
        "line_dynamic_db": Param("float", 10.0, "line peaks more than this below the line's "
                                 "strongest peak are taken for its sidelobes, dB",
                                 check=positive, unit="dB"),
        "min_separation": Param("float", 4.0, "minimum separation of peaks, deg",
                                check=lambda v: None if v >= 0 else "must be >= 0", unit="deg"),
        "peak_widths": Param("float", 0.0, "minimum separation in half-power widths of the "
                             "stronger peak, measured on the row (0: off); for "
                             "mvdr/music beams use min_separation = 0, peak_widths = 1",
                             check=lambda v: None if v >= 0 else "must be >= 0"),
        "lr_rejection_db": Param("float", 10.0, "relative-bearing beams: a peak this far above "
                                 "its mirror beam is taken as resolved to its side, dB",
                                 check=positive, unit="dB"),
        "max_peaks": Param("int", 8, "peaks per snapshot (per line)", check=positive),
        "clean": Param("bool", False, "azimuth x elevation beams: the peaks are the components "
                       "of a CLEAN of the scan (sources below a stronger one's sidelobes; "
                       "threshold_db over the fitted noise power)"),
        "clean_dynamic_db": Param("float", 20.0, "clean: components more than this below the "
                                  "strongest are dropped, dB", check=positive, unit="dB"),
        "max_lines": Param("int", 16, "lines per snapshot", check=positive),
        "tpsw_window": Param("int", 32, "TPSW half-window, bins", check=positive, unit="bins"),
        "tpsw_gap": Param("int", 3, "TPSW half-gap, bins", unit="bins"),
        "tpsw_clip": Param("float", 2.0, "TPSW clipping ratio", check=positive),
        "ref": Param("float", None, "reference amplitude for dB, in sample units (default: "
                     "1 µPa for data in Pa, full scale for data in FS)", check=positive,
                     unit="sample units"),
    }

    _lr = False
    _warned = False
    _warned_azel = False
    _columns = COLUMNS

    def _lr_row(self, rows: dict[str, list], rel: float, lev: float, heading: float,
                level_db: np.ndarray, axis: np.ndarray) -> None:
        """Columns of a peak on relative-bearing beams: resolved to its side when it stands
        ``lr_rejection_db`` over the level at its mirror bearing −β (interpolated)."""
        mirror = float(np.interp(-rel, axis, level_db))
        rows["cone_deg"].append(abs(rel))
        rows["rel_bearing_deg"].append(rel)
        if lev - mirror >= self.lr_rejection_db:
            brg = (heading + rel) % 360.0
            rows["bearing_port_deg"].append(brg)
            rows["bearing_stbd_deg"].append(brg)
            rows["side"].append(1.0 if rel > 0 else -1.0)
        else:
            rows["bearing_port_deg"].append((heading - abs(rel)) % 360.0)
            rows["bearing_stbd_deg"].append((heading + abs(rel)) % 360.0)
            rows["side"].append(0.0)

    def _check_separation(self, level_db: np.ndarray, axis: np.ndarray, peaks: list) -> None:
        """Warn once when the fixed ``min_separation`` exceeds twice the half-power width of
        the strongest peak measured on the row (resolved sources may be hidden)."""
        if self._warned or not peaks or self.min_separation <= 0:
            return
        width = half_power_width(level_db, axis, peaks[0][2])
        if self.min_separation > 2.0 * width:
            self._warned = True
            warnings.warn(f"stage {self.name!r}: key 'min_separation' ({self.min_separation:g}"
                          f" deg) exceeds twice the measured half-power width of the peaks "
                          f"({width:.2f} deg): sources closer than that are merged; for "
                          "adaptive beams set min_separation = 0 and peak_widths = 1",
                          stacklevel=2)

    def validate(self) -> None:
        if not (self.broadband or self.lines):
            raise ConfigError(f"stage {self.name!r}: key 'broadband' and key 'lines' are both "
                              "false: nothing to detect")
        if not 0 <= self.tpsw_gap < self.tpsw_window:
            raise ConfigError(f"stage {self.name!r}: key 'tpsw_gap' must be in [0, "
                              f"tpsw_window), got {self.tpsw_gap}")

    def _rows(self, t: float, heading: float, level_db: np.ndarray, cone: np.ndarray,
              thr_db: float, f_lo: float, f_hi: float, rows: dict[str, list],
              dynamic_db: float = np.inf, offset_db: float = np.nan) -> None:
        noise_db = float(np.median(level_db))
        floor = max(noise_db + thr_db, float(level_db.max()) - dynamic_db)
        peaks = pick_peaks(level_db, cone, floor, self.min_separation, self.max_peaks,
                           self.peak_widths)
        self._check_separation(level_db, cone, peaks)
        for pos, lev, _ in peaks:
            rows["time"].append(t)
            if self._lr:
                self._lr_row(rows, pos, lev, heading, level_db, cone)
            else:
                rows["cone_deg"].append(pos)
                rows["bearing_port_deg"].append((heading - pos) % 360.0)
                rows["bearing_stbd_deg"].append((heading + pos) % 360.0)
            rows["level_db"].append(lev)
            rows["snr_db"].append(lev - noise_db)
            rows["freq_lo"].append(f_lo)
            rows["freq_hi"].append(f_hi)
            rows["spl_db"].append(lev - offset_db)

    def process(self, blocks: Iterator[Block]) -> Iterator[Block]:
        out = None
        idx = None
        for b in blocks:
            check_power_block(self, b)
            cone = np.asarray(b.beams, float)
            if getattr(b.meta, "beam_mode", "cone") == "azel":
                yield self._azel(b)
                continue
            if cone.ndim != 1:
                raise ConfigError(f"stage {self.name!r}: needs cone-angle beams "
                                  "(beams = {start, stop, count}) or relative bearings")
            if idx is None:
                idx = band_bins(b.freqs, self.band, f"stage {self.name!r}")
                out = self.products("bearings")
                self._lr = getattr(b.meta, "beam_mode", "cone") == "lr"
                self._columns = COLUMNS + (("rel_bearing_deg", "side") if self._lr else ())
            times = snapshot_times(b)
            heads = np.asarray(b.meta.headings, float)
            df = float(b.meta.df)
            rows: dict[str, list] = {k: [] for k in self._columns}
            lref = 10 * np.log10(reference_amplitude(recording_units(self.ctx.recording),
                                                     self.ref)**2)
            off_bb = received_level_offset_db(b, broadband=True)
            off_line = received_level_offset_db(b, broadband=False)
            for s in range(b.data.shape[0]):
                p = b.data[s]  # (F, B)
                if self.broadband:
                    bp = p[idx].sum(axis=0, dtype=np.float64)
                    self._rows(times[s], heads[s], 10 * np.log10(np.maximum(bp, 1e-300)) - lref,
                               cone, self.threshold_db, float(b.freqs[idx[0]]),
                               float(b.freqs[idx[-1]]), rows, offset_db=off_bb)
                if self.lines:
                    self._lines(p, b.freqs, times[s], heads[s], cone, df, lref, rows, off_line)
            if out is not None and rows["time"]:
                out.append(**{k: np.asarray(v, float) for k, v in rows.items()})
            yield b

    def _azel(self, b: Block) -> Block:
        """Rows of azimuth × elevation beams (``cbf_azel``): 2-D peaks of the band power
        (:mod:`arrayproc.stages.passive.bearings_azel`); narrowband lines are not picked."""
        if self.lines and not self._warned_azel:
            self._warned_azel = True
            warnings.warn(f"stage {self.name!r}: azimuth x elevation beams carry band power "
                          "only: key 'lines' is ignored", stacklevel=2)
        out = self.products("bearings")
        times = snapshot_times(b)
        heads = np.asarray(b.meta.headings, float)
        f_c, width = float(b.freqs[0]), float(b.meta.df)
        lref = 10 * np.log10(reference_amplitude(recording_units(self.ctx.recording),
                                                 self.ref)**2)
        off = received_level_offset_db(b, broadband=True)
        rows: dict[str, list] = {k: [] for k in COLUMNS + AZEL_COLUMNS}
        pattern = None
        if self.clean:
            from arrayproc.stages.passive.azel_clean import AzelPattern
            az, el, _ = grid_axes(b.beams)
            pattern = AzelPattern(b.positions, self.ctx.sound_speed, az, el,
                                  f_c - 0.5 * width, f_c + 0.5 * width)
        for s in range(b.data.shape[0]):
            p = b.data[s].sum(axis=0, dtype=np.float64)  # (D,): the one band cell
            level = 10 * np.log10(np.maximum(p, 1e-300)) - lref
            azel_rows(self, level, b.beams, times[s], heads[s], f_c - 0.5 * width,
                      f_c + 0.5 * width, off, rows, pattern)
        if out is not None and rows["time"]:
            out.append(**{k: np.asarray(v, float) for k, v in rows.items()})
        return b

    def _lines(self, p: np.ndarray, freqs: np.ndarray, t: float, heading: float,
               cone: np.ndarray, df: float, lref: float, rows: dict[str, list],
               offset_db: float = np.nan) -> None:
        spec = np.ascontiguousarray(p.T, dtype=np.float64)  # (B, F)
        bg = tpsw(spec, self.tpsw_window, self.tpsw_gap, self.tpsw_clip)
        ratio_db = tpsw_db(spec, bg)
        best = ratio_db.max(axis=0)  # (F,)
        left = np.r_[-np.inf, best[:-1]]
        right = np.r_[best[1:], -np.inf]
        cand = np.flatnonzero((best > left) & (best >= right) & (best >= self.line_threshold_db))
        cand = cand[np.argsort(-best[cand], kind="stable")][: self.max_lines]
        for fi in np.sort(cand):
            row_db = 10 * np.log10(np.maximum(spec[:, fi], 1e-300)) - lref
            self._rows(t, heading, row_db, cone, self.line_threshold_db,
                       float(freqs[fi] - 0.5 * df), float(freqs[fi] + 0.5 * df), rows,
                       self.line_dynamic_db, offset_db)
