"""``active_beams``: beam time series of each ping's receive window (thesis ch. 4, the first
step of the active chain; beamformer of :mod:`arrayproc.stages.active.beamform`, eq. (2.8)).

For every transmission in the recording's ``/active/pings`` the stage gathers the samples from
the transmission time t_p to t_p + ``window_s`` + the pulse length (``window_s`` = 0: up to the
next transmission, or the recording's end), beamforms them in the frequency domain over the
waveform's band and yields one block per ping: complex baseband beam series, domain
``BEAM_TIME`` (time x beam: a transposed view of a beam-major (B, K) complex64 array) at
``fs = fs_bb``, ``t0 = t_p``, with :class:`arrayproc.chain.domains.PingMeta` (``fc`` the
baseband's lowest frequency f0; ``extra``: ``plan``, the
:class:`arrayproc.stages.active.bank.BandPlan`, and ``n_lags``, lags 0 ... n_lags-1 being
complete echoes inside the window). Input blocks are consumed, not
passed on; memory holds one window of hydrophone samples and the beams of one ping.

Direct blast (``blank_direct = true``, or a list of waveform names or kinds such as
``["bpsk"]`` to blank only those pings; an entry that is neither a waveform of the recording
nor a kind is a configuration error): the projector's own pulse reaches element n at
t_p + |p − r_n|/c (p the projector's body-frame position from ``/active``, r_n the element's)
and lasts the pulse length T; its matched-filter response, a sidelobe plateau −10 log10 N
below a peak some 100 dB above the echoes (thesis eq. (4.5)), covers lags up to T, i.e. ranges
up to about cT/2. Blanking sets each element's samples in
[t_p + |p − r_n|/c − m, t_p + |p − r_n|/c + T + m] (m = ``blank_margin_s``) to zero before
beamforming, as a receiver gated off during transmission: the plateau goes, and an echo from
bistatic delay τ < T keeps the part of it received after the gate (SNR loss about
10 log10(τ/T) for τ < T, none beyond).
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from typing import Any

import numpy as np

from arrayproc.chain import Block, Param, Stage, register
from arrayproc.chain.domains import Domain, PingMeta
from arrayproc.errors import ConfigError

from . import _common as cm
from .bank import band_plan
from .beamform import beam_axis, beam_series, element_advances

_UNKNOWN = 1 << 62  # a window whose end is not known yet (a recording still growing)


@register
class ActiveBeams(Stage):
    """Beam time series per ping receive window (see module doc)."""

    kind = "active_beams"
    accepts = frozenset({Domain.TIME})
    produces = Domain.BEAM_TIME
    params = {
        "beams": Param("table", {"start": 0.0, "stop": 180.0, "count": 181},
                       "cone angles {start, stop, count} or {bearings, elevations}, deg",
                       unit="deg"),
        "window_s": Param("float", 0.0, "receive window after each transmission, s (0: up to "
                          "the next transmission)", unit="s"),
        "band": Param("band", None, "[lo, hi] Hz kept as complex baseband (default: the "
                      "waveform's main lobe widened by the Doppler of +-15 m/s)", unit="Hz"),
        "shading": Param("str", "hann", "array shading", choices=("none", "hann", "hamming")),
        "threads": Param("int", 0, "FFT and beamforming threads (0: all cores)"),
        "blank_direct": Param("any", False, "zero each element's samples during the direct "
                              "arrival of the ping (projector offset from /active): true, "
                              "false, or a list of waveform names or kinds, e.g. [\"bpsk\"]"),
        "blank_margin_s": Param("float", 0.02, "extra time blanked before and after the "
                                "direct arrival, s", unit="s"),
    }

    def validate(self) -> None:
        w = f"stage {self.name!r}"
        if self.window_s < 0:
            raise ConfigError(f"{w}: key 'window_s' must be >= 0 s, got {self.window_s}")
        if self.blank_margin_s < 0:
            raise ConfigError(f"{w}: key 'blank_margin_s' must be >= 0 s, got "
                              f"{self.blank_margin_s}")
        self._blank = blank_selection(self.blank_direct, w)
        try:
            self.beam_axis, self._dirs, self.beam_mode = beam_axis(self.beams)
        except ConfigError as e:
            raise ConfigError(f"{w}: {e}") from None
        self._tau_key = None

    def _workers(self) -> int:
        return self.threads if self.threads > 0 else (os.cpu_count() or 1)

    def _window(self, act, i: int, fs: float, n_total: int | None) -> tuple[int, int, int]:
        """(first sample, samples to transform, complete lags) of ping i; ``n_total`` None
        while the recording still grows (``process --follow``): the window the schedule
        gives, and for the last ping of a window up to the recording's end, none yet."""
        tp = float(act.time[i])
        wf = act.waveforms[act.waveform[i]]
        s0 = int(round(tp * fs))
        n_pulse = int(np.ceil(wf.duration * fs)) + 1
        if self.window_s > 0:
            span = self.window_s
        elif i + 1 < act.time.size:
            span = float(act.time[i + 1]) - tp
        elif n_total is None:
            return s0, _UNKNOWN, _UNKNOWN
        else:
            span = n_total / fs - tp
        n_lag = max(1, int(round(span * fs)))
        # lags whose whole echo lies inside the recording
        if n_total is not None:
            n_lag = max(1, min(n_lag, n_total - s0 - n_pulse))
        return s0, n_lag + n_pulse, n_lag

    def process(self, blocks: Iterator[Block]) -> Iterator[Block]:
        rec = self.ctx.recording
        where = f"stage {self.name!r}"
        act = cm.schedule(rec, where)
        c = self.ctx.sound_speed
        fs = rec.fs
        # a recording still being written (process --follow) says so with ``growing``: the
        # pings whose windows are complete go as they complete, the others when it stops
        growing = bool(getattr(rec, "growing", False))
        n_total = None if growing else rec.n_samples
        wins = [self._window(act, i, fs, n_total) for i in range(act.time.size)]
        self._blank_wf = blanked_waveforms(self._blank, act.waveforms, where,
                                           getattr(rec, "path", ""))
        plans = {}
        for name, wf in act.waveforms.items():
            band = tuple(self.band) if self.band is not None else cm.default_band(wf, c, fs)
            plans[name] = band
        buf = np.zeros((0, 0), np.float32)
        buf_start = 0
        nxt = 0  # next ping to emit
        positions = None
        for b in blocks:
            if growing and not getattr(rec, "growing", False):  # its final length is known
                growing, n_total = False, rec.n_samples
                wins[nxt:] = [self._window(act, i, fs, n_total) for i in range(nxt, len(wins))]
            x = b.data[: b.meta.n_valid]
            s0 = int(b.meta.sample0)
            positions = b.positions
            if buf.shape[0] == 0 or buf_start + buf.shape[0] != s0:
                buf, buf_start = np.asarray(x, np.float32), s0
            else:
                buf = np.concatenate([buf, x])
            end = buf_start + buf.shape[0]
            while nxt < len(wins) and (wins[nxt][0] + wins[nxt][1] <= end
                                       or (n_total is not None and end >= n_total)):
                yield self._ping(act, nxt, wins[nxt], buf, buf_start, plans, positions, fs, c)
                nxt += 1
            keep = wins[nxt][0] if nxt < len(wins) else end
            drop = max(0, min(keep - buf_start, buf.shape[0]))
            if drop:
                buf = buf[drop:]
                buf_start += drop

    def _ping(self, act, i: int, win: tuple[int, int, int], buf: np.ndarray, buf_start: int,
              plans: dict, positions: np.ndarray, fs: float, c: float) -> Block:
        s0, n, n_lag = win
        x = np.zeros((n, buf.shape[1]), np.float32)
        a = max(s0, buf_start)
        bnd = min(s0 + n, buf_start + buf.shape[0])
        if bnd > a:
            x[a - s0:bnd - s0] = buf[a - buf_start:bnd - buf_start]
        name = act.waveform[i]
        if name in self._blank_wf:
            blank_direct(x, s0 / fs - float(act.time[i]), positions, act.projector,
                         act.waveforms[name].duration, fs, c, self.blank_margin_s)
        plan = band_plan(fs, n, plans[name])
        key = (positions.tobytes(), c)
        if key != self._tau_key:
            self._tau = element_advances(positions, self._dirs, self.beam_mode, c)
            self._w = cm.shading(self.shading, positions)
            self._tau_key = key
        y = beam_series(x, plan, self._tau, self._w, workers=self._workers())
        tp = float(act.time[i])
        pose = self.ctx.recording.pose(tp)
        n_lags = min(plan.n_bins, int(np.floor(n_lag * plan.fs_bb / fs)))
        meta = PingMeta(i, name, tp, plan.f0, float(pose.speed), float(pose.heading),
                        np.asarray(act.projector, float),
                        {"plan": plan, "n_lags": n_lags, "beam_mode": self.beam_mode})
        return Block(y.T, Domain.BEAM_TIME, tp, n / fs, plan.fs_bb, positions, pose=pose,
                     beams=self.beam_axis, index=i, meta=meta)


WAVEFORM_KINDS = ("bpsk", "cw", "hfm", "lfm")


def blank_selection(value: Any, where: str) -> bool | frozenset[str]:
    """Check the ``blank_direct`` key: true/false, or a non-empty list of waveform names or
    kinds (returned as a frozenset).

    Raises ConfigError (one line, naming the stage and the key) otherwise.
    """
    if isinstance(value, bool):
        return value
    if (isinstance(value, (list, tuple)) and value
            and all(isinstance(v, str) and v.strip() for v in value)):
        return frozenset(value)
    raise ConfigError(f"{where}: key 'blank_direct' must be true, false or a non-empty list of "
                      f"waveform names or kinds (e.g. [\"bpsk\"]), got {value!r}")


def blanked_waveforms(sel: bool | frozenset[str], waveforms: dict, where: str,
                      path: str = "") -> frozenset[str]:
    """Names of the recording's waveforms whose pings are blanked.

    Parameters
    ----------
    sel : bool or frozenset of str
        From :func:`blank_selection`: all, none, or names/kinds; an entry matches a waveform
        whose name or kind (bpsk, cw, hfm, lfm) it equals.
    waveforms : dict
        The recording's ``/active/waveforms``: name -> waveform (with ``kind``).
    where, path : str
        Stage and recording, for the error message.

    Returns
    -------
    frozenset of str
        Waveform names.

    Raises
    ------
    ConfigError
        An entry that is neither a waveform of the recording nor a waveform kind (a typo).
    """
    if isinstance(sel, bool):
        return frozenset(waveforms) if sel else frozenset()
    bad = sorted(x for x in sel if x not in waveforms and x not in WAVEFORM_KINDS)
    if bad:
        raise ConfigError(f"{where}: key 'blank_direct' names {bad[0]!r}, neither a waveform of "
                          f"{path or 'the recording'} ({', '.join(sorted(waveforms))}) nor a "
                          f"waveform kind ({', '.join(WAVEFORM_KINDS)})")
    return frozenset(n for n, wf in waveforms.items() if n in sel or wf.kind in sel)


def direct_gate(positions: np.ndarray, projector: np.ndarray, duration: float, fs: float,
                c: float, margin: float, t0: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Rows of a receive window holding the direct arrival at each element.

    Parameters
    ----------
    positions : (C, 3) ndarray
        Element positions, body frame, m.
    projector : (3,) ndarray
        Projector position, same frame, m.
    duration : float
        Pulse length T, s.
    fs : float
        Sample rate, Hz.
    c : float
        Sound speed, m/s.
    margin : float
        Time added before and after, s.
    t0 : float
        Time of row 0 after the transmission, s.

    Returns
    -------
    first, stop : (C,) int ndarrays
        Rows ``first`` (inclusive) to ``stop`` (exclusive) covering
        [|p − r_n|/c − margin, |p − r_n|/c + T + margin] after the transmission, rounded
        outwards.
    """
    d = np.linalg.norm(np.asarray(positions, float) - np.asarray(projector, float), axis=1) / c
    first = np.floor((d - margin - t0) * fs).astype(np.int64)
    stop = np.ceil((d + duration + margin - t0) * fs).astype(np.int64) + 1
    return first, stop


def blank_direct(x: np.ndarray, t0: float, positions: np.ndarray, projector: np.ndarray,
                 duration: float, fs: float, c: float, margin: float) -> None:
    """Zero, in place, each element's samples of the direct arrival (see :func:`direct_gate`).

    Parameters
    ----------
    x : (n, C) ndarray
        Receive window, row 0 at ``t0`` s after the transmission.
    t0, positions, projector, duration, fs, c, margin
        As :func:`direct_gate`.
    """
    first, stop = direct_gate(positions, projector, duration, fs, c, margin, t0)
    n = x.shape[0]
    for ch in range(x.shape[1]):
        a, b = max(0, int(first[ch])), min(n, int(stop[ch]))
        if b > a:
            x[a:b, ch] = 0.0
