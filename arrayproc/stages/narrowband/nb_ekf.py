"""``nb_ekf``: narrowband EKF bearing/frequency tracker on DFT-filtered hydrophone samples
(thesis 3.2.1, eqs. (3.18)-(3.23), figs. 3.4-3.6).

Input: the ``dft_filter`` stage's output, real (thesis 3.2.1.1) or complex baseband, from a line
array along the body x axis. Every sample updates the EKF of :mod:`.ekf` (state cone angle and
frequency; own speed from the navigation through the Doppler factor 1 + U cos θ / c; amplitude
estimated and divided out, thesis 3.2.1.3; re-initialised every ``reinit_s``; two staggered
filters with ``dual``). Start values: numbers, or ``"auto"`` (the strongest line in the input
band over the first ``AUTO_SPAN_S`` seconds, then a CBF scan at that line, :mod:`.initial`).

Writes products ``nb_tracks`` (DESIGN section 5) at ``output_rate``: ``time`` s, ``cone_deg``,
``freq_hz`` (without own Doppler), ``sigma_cone_deg``, ``sigma_freq_hz``, ``filter`` (index of
the staggered filter that gave the row). Blocks pass through unchanged.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any

import numpy as np

from arrayproc.chain import Block, Param, Stage, positive, register
from arrayproc.errors import ConfigError
from arrayproc.stages.narrowband.ekf import NarrowbandEKF
from arrayproc.stages.narrowband.initial import cone_scan, strongest_line

#: Seconds of input used for the automatic start values.
AUTO_SPAN_S = 4.0
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
    params = {
        "freq": Param("any", "auto", "initial tonal frequency, Hz, or \"auto\"",
                      check=_auto_or("Hz", 0.0, None)),
        "cone": Param("any", "auto", "initial cone angle, deg (0 forward), or \"auto\"",
                      check=_auto_or("deg", 0.0, 180.0)),
        "sigma_cone_deg": Param("float", 0.05, "process noise of the cone, deg/√s",
                                check=positive),
        "sigma_freq_hz": Param("float", 0.01, "process noise of the frequency, Hz/√s",
                               check=positive),
        "p0_cone_deg": Param("float", 2.0, "initial standard deviation of the cone, deg",
                             check=positive),
        "p0_freq_hz": Param("float", 0.5, "initial standard deviation of the frequency, Hz",
                            check=positive),
        "noise": Param("any", "auto", "measurement noise power of the input samples "
                       "(real: variance, complex: E|v|²), or \"auto\" to estimate it",
                       check=_auto_or("", 1e-300, None)),
        "reinit_s": Param("float", 30.0, "re-initialisation period of each filter, s",
                          check=positive),
        "dual": Param("bool", True, "two filters re-initialised half a period apart"),
        "output_rate": Param("float", 10.0, "rows per second written to nb_tracks, Hz",
                             check=positive),
    }

    def validate(self) -> None:
        self._ekf: NarrowbandEKF | None = None

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
        fc = float(b.meta.get("fc", 0.0)) if np.iscomplexobj(y) else None
        band = b.meta.get("band")
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
            reinit_s=self.reinit_s, dual=self.dual)

    def _track(self, y: np.ndarray, b: Block, x: np.ndarray, speed: float, out) -> None:
        s0 = int(b.meta.get("sample0", round(b.t0 * b.fs)))
        r = self._ekf.process(y, s0 / b.fs, b.fs, speed)
        step = max(1, int(round(b.fs / self.output_rate)))
        keep = (s0 + np.arange(y.shape[0])) % step == 0
        if out is not None and keep.any():
            out.append(time=r["time"][keep], cone_deg=r["cone_deg"][keep],
                       freq_hz=r["freq_hz"][keep], sigma_cone_deg=r["sigma_cone_deg"][keep],
                       sigma_freq_hz=r["sigma_freq_hz"][keep],
                       filter=r["filter"][keep].astype(np.int8))

    def process(self, blocks: Iterator[Block]) -> Iterator[Block]:
        out = self.products("nb_tracks", reinit_s=self.reinit_s, dual=int(self.dual))
        pending: list[Block] = []
        for b in blocks:
            if b.domain != ("time", "channel"):
                raise ConfigError(f"stage {self.name!r}: needs time-domain input (a "
                                  f"dft_filter output), got {b.domain}")
            if self._ekf is None:
                pending.append(b)
                span = sum(p.meta.get("n_valid", p.data.shape[0]) for p in pending) / b.fs
                if span < AUTO_SPAN_S and (self.freq == "auto" or self.cone == "auto"):
                    continue
                y0 = np.concatenate([p.data[:p.meta.get("n_valid", p.data.shape[0])]
                                     for p in pending])
                x = self._x(b)
                speed = float(b.pose.speed) if b.pose is not None else 0.0
                self._start(y0, b, x, speed)
                for p in pending:
                    n = p.meta.get("n_valid", p.data.shape[0])
                    self._track(p.data[:n], p, x, speed, out)
                    yield p
                pending = []
                continue
            n = b.meta.get("n_valid", b.data.shape[0])
            speed = float(b.pose.speed) if b.pose is not None else 0.0
            self._track(b.data[:n], b, self._x(b), speed, out)
            yield b
        if pending:  # a stream shorter than AUTO_SPAN_S
            y0 = np.concatenate([p.data[:p.meta.get("n_valid", p.data.shape[0])]
                                 for p in pending])
            b = pending[-1]
            x = self._x(b)
            speed = float(b.pose.speed) if b.pose is not None else 0.0
            self._start(y0, b, x, speed)
            for p in pending:
                n = p.meta.get("n_valid", p.data.shape[0])
                self._track(p.data[:n], p, x, speed, out)
                yield p

    def warmup_seconds(self, fs: float) -> float:
        # A recursive filter never forgets completely; one re-initialisation period is the
        # margin after which a segment's output filter has restarted inside the margin.
        return self.reinit_s
