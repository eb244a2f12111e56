"""Radiated signals of the passive sources at 1 m, sampled at the source rate (2 × fs).

A source's signal s(t) (Pa at 1 m, t = emission time in s since the recording's start) is the
sum of
- tonals A cos(2π f t + φ), A = √2 · 1 µPa · 10^(SL/20) (SL = RMS level, dB re 1 µPa @ 1 m),
  φ given or drawn from the source's own seeded stream; optionally unsteady: a linear
  frequency drift (phase 2π(f t + ḟ t²/2)), a random-walk phase of coherence time T_c and a
  log-amplitude fade (``arrayproc.sim.unsteady``);
- band-limited Gaussian noise of one-sided spectral level L (dB re 1 µPa²/Hz @ 1 m) over
  [lo, hi], optionally tilted by ``slope_db_per_octave``; with ``model = "speed"`` the band's
  total level follows SPL paper eq. (12), SL(v) = 170 + 53 log10(v / 5.14 m/s) dB re 1 µPa
  @ 1 m (log10, Ross' trend), spread over the band, with v the source's speed at emission.

Sample m is at time m / fs_src; blocks are requested by absolute index (negative before the
recording's start), so chunking never changes a value.
"""

from __future__ import annotations

import numpy as np

from arrayproc.acoustics.source_level import ROSS_SURFACE_SHIP
from arrayproc.sim.motion import TrackMover
from arrayproc.sim.scenario import Broadband, SourceSpec
from arrayproc.sim.signals import UPA2, ShapedNoise
from arrayproc.sim.unsteady import fading_gain, random_walk_phase

KEY_TONAL = 11
KEY_BROADBAND = 12
KEY_UNSTEADY = 13
LEVEL_GRID = 256  # source samples between evaluations of the speed-dependent level


def tonal_amplitude(level_db: float) -> float:
    """Peak amplitude (Pa at 1 m) of a tonal of RMS level ``level_db`` dB re 1 µPa @ 1 m."""
    return float(np.sqrt(2.0) * 1e-6 * 10 ** (level_db / 20.0))


def band_shape(bb: Broadband):
    """Relative PSD shape in the band (1 at the low edge, or at 1 Hz when lo < 1 Hz)."""
    lo, hi = bb.band
    fref = max(lo, 1.0)
    slope = bb.slope_db_per_octave

    def shape(f: np.ndarray) -> np.ndarray:
        f = np.asarray(f, dtype=float)
        inside = (f >= lo) & (f <= hi)
        s = 10 ** (slope * np.log2(np.maximum(f, 1e-9) / fref) / 10.0)
        return np.where(inside, s, 0.0)

    return shape


def band_equivalent_width(bb: Broadband) -> float:
    """∫ shape(f) df over the band (Hz): the band's power per unit spectral level."""
    f = np.linspace(bb.band[0], bb.band[1], 4001)
    s = band_shape(bb)(f)
    return float(np.sum((s[1:] + s[:-1]) * 0.5 * np.diff(f)))


class SourceSignal:
    """The signal a passive source radiates, by absolute source-sample index."""

    def __init__(self, spec: SourceSpec, mover: TrackMover, fs_src: float, seed: int,
                 index: int) -> None:
        self.spec = spec
        self.mover = mover
        self.fs_src = float(fs_src)
        rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(KEY_TONAL, index)))
        rand_phase = rng.uniform(0.0, 2 * np.pi, len(spec.tonals))
        self.freqs = np.array([t.freq for t in spec.tonals], dtype=float)
        self.amps = np.array([tonal_amplitude(t.level_db) for t in spec.tonals])
        self.phases = np.array([np.deg2rad(t.phase_deg) if t.phase_deg is not None
                                else rand_phase[i] for i, t in enumerate(spec.tonals)])
        self.drifts = np.array([t.drift_hz_per_s for t in spec.tonals], dtype=float)
        #: per tonal: random-walk phase process (or None), fading process and normalisation
        self.unsteady = []
        for i, t in enumerate(spec.tonals):
            ph = (random_walk_phase(t.coherence_time, fs_src, seed, (KEY_UNSTEADY, index, i, 0))
                  if t.coherence_time is not None else None)
            fade = (fading_gain(t.fading_db, t.fading_time, fs_src, seed,
                                (KEY_UNSTEADY, index, i, 1)) if t.fading_db > 0 else None)
            self.unsteady.append((ph, fade))
        self.noise = None
        bb = spec.broadband
        if bb is not None:
            shape = band_shape(bb)
            self.noise = ShapedNoise(fs_src, seed, (KEY_BROADBAND, index), 1,
                                     psd=lambda f: UPA2 * shape(f), white_psd=UPA2)
            self.bandwidth = band_equivalent_width(bb)

    def spectral_level_db(self, t: np.ndarray) -> np.ndarray:
        """Broadband spectral level at the band's reference frequency (dB re 1 µPa²/Hz @ 1 m)
        at emission times t."""
        bb = self.spec.broadband
        t = np.asarray(t, dtype=float)
        if bb.model == "flat":
            return np.full(t.shape, bb.level_db)
        v = np.hypot(*self.mover.state3(t)[1][:, :2].T)
        return ROSS_SURFACE_SHIP(v) - 10 * np.log10(self.bandwidth)

    def block(self, m0: int, m1: int) -> np.ndarray:
        """Samples m0 … m1−1 (float64, Pa at 1 m)."""
        m = np.arange(m0, m1, dtype=np.int64)
        out = np.zeros(m.size)
        for f, a, ph, dr, (walk, fade) in zip(self.freqs, self.amps, self.phases, self.drifts,
                                              self.unsteady):
            x = f * m.astype(float) / self.fs_src  # cycles; reduce before the cosine
            if dr != 0.0:  # f(t) = f + drift·t: phase 2π(f t + drift t²/2)
                tm = m.astype(float) / self.fs_src
                x = x + 0.5 * dr * tm * tm
            arg = 2 * np.pi * (x - np.floor(x)) + ph
            if walk is not None:
                arg = arg + walk.at_samples(m0, m1)
            if fade is None:
                out += a * np.cos(arg)
            else:
                proc, norm = fade
                out += a * norm * 10 ** (proc.at_samples(m0, m1) / 20.0) * np.cos(arg)
        if self.noise is not None:
            nb = self.noise.block(m0, m1)[:, 0]
            if self.spec.broadband.model == "flat":
                nb = nb * 10 ** (self.spec.broadband.level_db / 20.0)
            else:  # level from the speed, evaluated every LEVEL_GRID samples (absolute grid)
                g0 = (m0 // LEVEL_GRID) * LEVEL_GRID
                tg = np.arange(g0, m1 + LEVEL_GRID, LEVEL_GRID)
                lv = self.spectral_level_db(tg / self.fs_src)
                nb = nb * 10 ** (lv[(m - g0) // LEVEL_GRID] / 20.0)
            out += nb
        return out
