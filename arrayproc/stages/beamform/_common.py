"""Element spectra of successive snapshots, for the stages that work per hydrophone and bin
(inverse beamforming, passive synthetic aperture, ETAM).

A *spectra block* has domain ``("snapshot", "freq", "channel")``: complex64 DFTs (unnormalised,
numpy sign convention) of ``nfft``-sample frames of every element, for the bins of a band.
Its ``meta`` holds per-snapshot ``times`` (centre, s), ``starts`` (first sample), ``headings``
(deg), ``positions_xy`` (reference point, m), plus ``nfft``, ``hop``, ``window`` and ``df``.

Thesis ch. 2 works with uniform line arrays; :func:`uniform_line` checks the geometry and
returns the element order and spacing those stages need.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from arrayproc.chain import Stage
from arrayproc.chain.block import Block
from arrayproc.chain.domains import Domain, SnapshotMeta
from arrayproc.dsp import fft
from arrayproc.dsp.bands import check_nyquist
from arrayproc.dsp.framing import FrameBuffer
from arrayproc.dsp.windows import time_taper
from arrayproc.errors import ConfigError
from arrayproc.stages.beamform.checks import warn_spatial_aliasing


def uniform_line(positions: np.ndarray, tol: float = 1e-3) -> tuple[np.ndarray, float]:
    """Check that the elements form a uniform line along the body x axis.

    Returns ``(order, spacing)``: channel indices from the forward end aft, and the element
    spacing δx (m). Raises ConfigError otherwise.
    """
    p = np.asarray(positions, float)
    if p.shape[0] < 2:
        raise ConfigError("needs a line array of at least 2 elements")
    if np.ptp(p[:, 1]) > tol or np.ptp(p[:, 2]) > tol:
        raise ConfigError("needs a line array along the body x axis (y and z constant)")
    order = np.argsort(-p[:, 0], kind="stable")
    d = -np.diff(p[order, 0])
    dx = float(np.mean(d))
    if dx <= 0 or np.max(np.abs(d - dx)) > tol * max(dx, 1.0):
        raise ConfigError("needs a uniformly spaced line array")
    return order, dx


def snapshot_seconds(rule: str, n_elements: int, spacing: float, speed: float) -> float:
    """Snapshot duration T_B (s) from the tow speed U (m/s).

    ``"psas"``: thesis eq. (2.32), T_B = N_H δx / U — successive apertures abut.
    ``"etam"``: thesis eq. (2.52), T_B = (N_H − 1) δx / (2U) — successive apertures half overlap.
    """
    if not speed > 0:
        raise ConfigError("the snapshot length follows from the tow speed, but the navigation "
                          "shows a stationary array; give the snapshot length explicitly")
    if rule == "psas":
        return n_elements * spacing / speed
    if rule == "etam":
        return (n_elements - 1) * spacing / (2.0 * speed)
    raise ConfigError(f"unknown snapshot rule {rule!r} (psas or etam)")


class SpectraFramer:
    """Turns time blocks into spectra blocks: frames of ``nfft`` every ``hop``, taper, rfft,
    band selection. Poses come from ``nav`` (a :class:`~arrayproc.geo.nav.Nav`) when given,
    else from each block's pose."""

    def __init__(self, nfft: int, hop: int, window: str = "none",
                 band: tuple[float, float] | None = None, nav=None) -> None:
        self.nfft, self.hop = int(nfft), int(hop)
        self.window = window
        self._taper = time_taper(window, self.nfft).astype(np.float32)
        self.band = band
        self.nav = nav
        self._fb = FrameBuffer(self.nfft, self.hop)
        self._bins: np.ndarray | None = None
        self.index = 0

    def _select(self, fs: float) -> np.ndarray:
        if self._bins is None:
            f = np.fft.rfftfreq(self.nfft, 1.0 / fs)
            lo, hi = self.band if self.band is not None else (0.0, np.inf)
            self._bins = np.flatnonzero((f >= lo) & (f <= hi))
            if self._bins.size == 0:
                raise ConfigError(f"band {self.band} holds no DFT bin (fs = {fs:g} Hz, "
                                  f"nfft = {self.nfft})")
            self.freqs = f[self._bins]
        return self._bins

    def push(self, b: Block) -> Block | None:
        frames, starts = self._fb.push(b.data[:b.meta.n_valid], b.meta.sample0)
        if frames.shape[0] == 0:
            return None
        bins = self._select(b.fs)
        # FFT along contiguous rows (channel-major), then back to (S, F, C) for the band only
        rows = np.ascontiguousarray(frames.transpose(0, 2, 1), dtype=np.float32)
        rows *= self._taper[None, None, :]
        spec = fft.rfft(rows, axis=2)
        x = np.ascontiguousarray(spec[:, :, bins[0]:bins[-1] + 1].transpose(0, 2, 1))
        times = (starts + 0.5 * self.nfft) / b.fs
        if self.nav is not None:
            pos, hd, _, spd = self.nav.at(times)
        else:
            pose = b.pose
            k = times.size
            pos = np.repeat(pose.position[None], k, 0) if pose else np.zeros((k, 2))
            hd = np.full(k, pose.heading if pose else 0.0)
            spd = np.full(k, pose.speed if pose else 0.0)
        out = Block(x.astype(np.complex64, copy=False), Domain.SPECTRA, starts[0] / b.fs,
                    (starts[-1] - starts[0] + self.nfft) / b.fs, b.fs, b.positions, b.pose,
                    self.freqs, None, self.index,
                    SnapshotMeta(times, hd, self.nfft, self.hop, self.window, b.fs / self.nfft,
                                 starts=starts, positions_xy=pos, speeds=spd))
        self.index += x.shape[0]
        return out


def line_geometry(name: str, positions: np.ndarray) -> tuple[np.ndarray, float]:
    """Element order and spacing of a uniform line array, or a ConfigError naming the stage."""
    try:
        return uniform_line(positions)
    except ConfigError as e:
        raise ConfigError(f"stage {name!r}: {e}") from None


def make_framer(stage: Stage, b: Block) -> SpectraFramer:
    """The element-spectra framer of a stage with ``snapshot``/``nfft``/``window``/``band``
    keys: the snapshot length from the nav speed (thesis eq. 2.32 or 2.52, rounded up to an
    FFT-friendly number of samples) or given."""
    if stage.snapshot == "nfft":
        nfft = stage.nfft
    else:
        _, dx = line_geometry(stage.name, b.positions)
        speed = b.pose.speed if b.pose is not None else 0.0
        try:
            tb = snapshot_seconds(stage.snapshot, b.positions.shape[0], dx, speed)
        except ConfigError as e:
            raise ConfigError(f"stage {stage.name!r}: {e}") from None
        # rounded up to an FFT-friendly length (at most a few per mille longer than T_B)
        nfft = fft.next_fast_len(int(round(tb * b.fs)))
    where = f"stage {stage.name!r}"
    check_nyquist(stage.band, b.fs / 2, where)
    f_max = b.fs / 2 if stage.band is None else min(b.fs / 2, float(stage.band[1]))
    warn_spatial_aliasing(where, b.positions, f_max, stage.ctx.sound_speed)
    rec = stage.ctx.recording
    nav = rec.nav if rec is not None else None
    return SpectraFramer(nfft, nfft, stage.window,
                         None if stage.band is None else tuple(stage.band), nav)


def element_spectra(stage: Stage, blocks: Iterator[Block]) -> Iterator[Block]:
    """The element-spectra blocks of a stage's input: time blocks are framed (see
    :func:`make_framer`), spectra blocks pass as they are."""
    framer: SpectraFramer | None = None
    for b in blocks:
        if b.domain is Domain.TIME:
            if framer is None:
                framer = make_framer(stage, b)
            spec = framer.push(b)
            if spec is not None:
                yield spec
        elif b.domain is Domain.SPECTRA:
            yield b
        else:
            raise ConfigError(f"stage {stage.name!r}: needs time or element-spectra input, "
                              f"got {b.domain}")


def rule_snapshot_seconds(stage: Stage) -> float | None:
    """T_B (s) of a stage with ``snapshot``/``nfft`` keys, known before data flows: given
    (``nfft``), that of element spectra from upstream, or from the recording's median nav
    speed (eq. 2.32 / 2.52, before rounding to an FFT size). None when unknown."""
    if stage.snapshot == "nfft":
        return stage.nfft / stage.fs_in if stage.fs_in else None
    up = stage.upstream.snapshot_seconds() if stage.upstream is not None else None
    if up is not None:
        return up
    rec = stage.ctx.recording
    if rec is None or rec.nav.time.size < 2:
        return None
    try:
        _, dx = uniform_line(rec.positions)
    except ConfigError:
        return None
    speed = float(np.median(rec.nav.at(rec.nav.time)[3]))
    if not speed > 0:
        return None
    return snapshot_seconds(stage.snapshot, rec.positions.shape[0], dx, speed)
