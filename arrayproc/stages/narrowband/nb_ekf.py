"""``nb_ekf``: narrowband EKF bearing/frequency tracker on DFT-filtered hydrophone samples
(thesis 3.2.1, eqs. (3.18)-(3.23), figs. 3.4-3.6).

Input: the ``dft_filter`` stage's output, real (thesis 3.2.1.1) or complex baseband, from a line
array along the body x axis. Every sample updates the EKF of :mod:`.ekf` (state cone angle and
frequency; own speed from the navigation through the Doppler factor 1 + U cos θ / c; amplitude
estimated and divided out, thesis 3.2.1.3; re-initialised every ``reinit_s``; two staggered
filters with ``dual``). Start values: numbers, or ``"auto"`` (the strongest line in the input
band over the first ``AUTO_SPAN_S`` seconds, then a CBF scan at that line, :mod:`.initial`).
``align_phase`` (default true) starts each filter with its model phase matched, which removes
the thesis's sidelobe jumps after re-initialisations at high SNR; ``spatial_doppler`` (default
true, eq. (3.18) as printed) can be turned off for the exact moving-array phase, which removes
a cone bias of U cos² θ / c near end-fire (both measured in ``docs/validation/narrowband.md``).
With ``baseline`` the per-sample CBF of thesis 3.2.1.1 (:mod:`.cbf_baseline`) is written too,
as group ``<name>_cbf`` with ``filter`` = −1.

Writes products ``nb_tracks`` (docs/formats.md) at ``output_rate``: ``time`` s, ``cone_deg``,
``freq_hz`` (without own Doppler), ``sigma_cone_deg``, ``sigma_freq_hz``, ``filter`` (index of
the staggered filter that gave the row). Blocks pass through unchanged.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any

import numpy as np

from arrayproc.chain import Block, Param, Stage, positive, register
from arrayproc.chain.domains import Domain
from arrayproc.errors import ConfigError
from arrayproc.stages.narrowband.cbf_baseline import cbf_track
from arrayproc.stages.narrowband.ekf import NarrowbandEKF
from arrayproc.stages.narrowband.initial import cone_scan, strongest_line

#: Seconds of input used for the automatic start values.
AUTO_SPAN_S = 4.0
#: Window of the CBF baseline's coarse scan and line frequency, s.
BASELINE_WINDOW_S = 4.0
#: Largest spread (m) of the element y and z coordinates still taken as a line array.
LINE_TOL_M = 1e-3


def _auto_or(kind: str, lo: float | None = None, hi: float | None = None):
    def check(v: Any) -> str | None:
        if v == "auto":
            return None
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            return f"expected \"auto\" or a number, got {v!r}"
        if lo is not None and v < lo or hi is not None and v > hi:
            return f"must be in [{lo}, {hi}] {kind}, got {v}"
        return None
    return check


@register
class NarrowbandEKFStage(Stage):
    """Narrowband EKF tracker (thesis 3.2.1); see the module docstring."""

    kind = "nb_ekf"
    accepts = frozenset({Domain.TIME})
    params = {
        "freq": Param("any", "auto", "initial tonal frequency, Hz, or \"auto\"",
                      check=_auto_or("Hz", 0.0, None), unit="Hz"),
        "cone": Param("any", "auto", "initial cone angle, deg (0 forward), or \"auto\"",
                      check=_auto_or("deg", 0.0, 180.0), unit="deg"),
        "sigma_cone_deg": Param("float", 0.05, "process noise of the cone, deg/√s",
                                check=positive, unit="deg/√s"),
        "sigma_freq_hz": Param("float", 0.01, "process noise of the frequency, Hz/√s",
                               check=positive, unit="Hz/√s"),
        "p0_cone_deg": Param("float", 2.0, "initial standard deviation of the cone, deg",
                             check=positive, unit="deg"),
        "p0_freq_hz": Param("float", 0.5, "initial standard deviation of the frequency, Hz",
                            check=positive, unit="Hz"),
        "noise": Param("any", "auto", "measurement noise power of the input samples "
                       "(real: variance, complex: E|v|²), or \"auto\" to estimate it",
                       check=_auto_or("", 1e-300, None)),
        "reinit_s": Param("float", 30.0, "re-initialisation period of each filter, s",
                          check=positive, unit="s"),
        "dual": Param("bool", True, "two filters re-initialised half a period apart"),
        "output_rate": Param("float", 10.0, "rows per second written to nb_tracks, Hz",
                             check=positive, unit="Hz"),
        "align_phase": Param("bool", True, "start each (re)initialised filter with its model "
                             "phase matched (false: the thesis's re-initialisation)"),
        "spatial_doppler": Param("bool", True, "own-speed Doppler factor on the element delays "
                                 "too, as thesis eq. (3.18) (false: exact moving-array phase, no "
                                 "end-fire bias)"),
        "baseline": Param("bool", False, "also write the per-sample CBF baseline (thesis "
                          "3.2.1.1) as nb_tracks group '<name>_cbf' (filter = -1)"),
    }

    def validate(self) -> None:
        # the key 'output_rate' would shadow Stage.output_rate(fs) (the rate of the series
        # passed on, unchanged here): keep the value under another name
        self.row_rate = float(self.__dict__.pop("output_rate"))
        self._ekf: NarrowbandEKF | None = None
        self._last_slot = -1.0
        self._cbf_last_slot = -1.0
        self._cbf_buf: list[tuple[np.ndarray, Block]] = []

    def _x(self, b: Block) -> np.ndarray:
        p = np.asarray(b.positions, float)
        if p.ndim != 2 or p.shape[0] < 2 or p.shape[1] < 1:
            raise ConfigError(f"stage {self.name!r}: needs a line array of at least 2 elements")
        if p.shape[1] >= 3 and (np.ptp(p[:, 1]) > LINE_TOL_M or np.ptp(p[:, 2]) > LINE_TOL_M):
            raise ConfigError(f"stage {self.name!r}: needs a line array along the body x axis "
                              "(element y and z constant)")
        return p[:, 0]

    def _start(self, y: np.ndarray, b: Block, x: np.ndarray, speed: float) -> None:
        c = self.ctx.sound_speed
        fc = float(b.meta.fc) if np.iscomplexobj(y) else None
        band = b.meta.band
        f_line = (strongest_line(y, b.fs, tuple(band) if band else None, fc or 0.0)
                  if self.freq == "auto" or self.cone == "auto" else None)
        if self.cone == "auto":
            cone = cone_scan(y, b.fs, f_line, x, c, fc or 0.0)[0]
        else:
            cone = float(self.cone)
        if self.freq == "auto":
            freq = f_line / (1.0 + speed * math.cos(math.radians(cone)) / c)
        else:
            freq = float(self.freq)
        self.start_values = (cone, freq)
        self.ctx.log(f"{self.name}: start cone {cone:.2f} deg, frequency {freq:.3f} Hz")
        self._ekf = NarrowbandEKF(
            x, cone, freq, c, fc=fc, p0=(self.p0_cone_deg, self.p0_freq_hz),
            q=(self.sigma_cone_deg, self.sigma_freq_hz),
            noise=None if self.noise == "auto" else float(self.noise),
            reinit_s=self.reinit_s, dual=self.dual, align_phase=self.align_phase,
            spatial_doppler=self.spatial_doppler)

    def _track(self, y: np.ndarray, b: Block, x: np.ndarray, speed: float, out,
               cbf_out=None) -> None:
        if self.baseline:
            self._baseline(y, b, cbf_out)
        s0 = int(b.meta.sample0)
        r = self._ekf.process(y, s0 / b.fs, b.fs, speed)
        # one row at the first sample at or after each multiple of 1 / output_rate
        slot = np.floor((s0 + np.arange(y.shape[0])) * (self.row_rate / b.fs) + 1e-9)
        prev = np.concatenate([[self._last_slot], slot[:-1]])
        keep = slot != prev
        self._last_slot = slot[-1] if slot.size else self._last_slot
        if out is not None and keep.any():
            out.append(time=r["time"][keep], cone_deg=r["cone_deg"][keep],
                       freq_hz=r["freq_hz"][keep], sigma_cone_deg=r["sigma_cone_deg"][keep],
                       sigma_freq_hz=r["sigma_freq_hz"][keep],
                       filter=r["filter"][keep].astype(np.int8))

    def _baseline(self, y: np.ndarray | None, b: Block | None, out, flush: bool = False) -> None:
        """Buffer samples and run the CBF baseline on windows of BASELINE_WINDOW_S."""
        if y is not None:
            self._cbf_buf.append((y, b))
        if not self._cbf_buf:
            return
        b0 = self._cbf_buf[0][1]
        n = sum(v.shape[0] for v, _ in self._cbf_buf)
        if n < BASELINE_WINDOW_S * b0.fs and not flush:
            return
        yy = np.concatenate([v for v, _ in self._cbf_buf])
        last = self._cbf_buf[-1][1]
        self._cbf_buf = []
        c = self.ctx.sound_speed
        fc = float(last.meta.fc) if np.iscomplexobj(yy) else 0.0
        band = last.meta.band
        speed = float(last.pose.speed) if last.pose is not None else 0.0
        r = cbf_track(yy, b0.fs, self._x(last), c, fc=fc, band=tuple(band) if band else None,
                      coarse_s=BASELINE_WINDOW_S, speed=speed)
        s0 = int(b0.meta.sample0)
        slot = np.floor((s0 + np.arange(yy.shape[0])) * (self.row_rate / b0.fs) + 1e-9)
        keep = slot != np.concatenate([[self._cbf_last_slot], slot[:-1]])
        self._cbf_last_slot = slot[-1]
        f = r["freq_hz"] / (1.0 + speed * np.cos(np.radians(r["cone_deg"])) / c)
        k = int(keep.sum())
        if out is not None and k:
            out.append(time=(s0 + np.flatnonzero(keep)) / b0.fs, cone_deg=r["cone_deg"][keep],
                       freq_hz=f[keep], sigma_cone_deg=np.full(k, np.nan),
                       sigma_freq_hz=np.full(k, np.nan), filter=np.full(k, -1, np.int8))

    def process(self, blocks: Iterator[Block]) -> Iterator[Block]:
        out = self.products("nb_tracks", reinit_s=self.reinit_s, dual=int(self.dual))
        cbf_out = (self.ctx.products.group(f"{self.name}_cbf", "nb_tracks", self.name,
                                           estimator="cbf")
                   if self.baseline and self.ctx.products is not None else None)
        pending: list[Block] = []
        for b in blocks:
            if self._ekf is None:
                pending.append(b)
                span = sum(p.meta.n_valid for p in pending) / b.fs
                if span < AUTO_SPAN_S and (self.freq == "auto" or self.cone == "auto"):
                    continue
                y0 = np.concatenate([p.data[:p.meta.n_valid]
                                     for p in pending])
                x = self._x(b)
                speed = float(b.pose.speed) if b.pose is not None else 0.0
                self._start(y0, b, x, speed)
                for p in pending:
                    n = p.meta.n_valid
                    self._track(p.data[:n], p, x, speed, out, cbf_out)
                    yield p
                pending = []
                continue
            n = b.meta.n_valid
            speed = float(b.pose.speed) if b.pose is not None else 0.0
            self._track(b.data[:n], b, self._x(b), speed, out, cbf_out)
            yield b
        if pending:  # a stream shorter than AUTO_SPAN_S
            y0 = np.concatenate([p.data[:p.meta.n_valid]
                                 for p in pending])
            b = pending[-1]
            x = self._x(b)
            speed = float(b.pose.speed) if b.pose is not None else 0.0
            self._start(y0, b, x, speed)
            for p in pending:
                n = p.meta.n_valid
                self._track(p.data[:n], p, x, speed, out, cbf_out)
                yield p
        if self.baseline:
            self._baseline(None, None, cbf_out, flush=True)

    def warmup_seconds(self, fs: float) -> float:
        # A recursive filter never forgets completely; one re-initialisation period is the
        # margin after which a segment's output filter has restarted inside the margin.
        return self.reinit_s
