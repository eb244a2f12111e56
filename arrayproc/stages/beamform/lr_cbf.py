"""``lr_cbf``: beams over relative bearing (−180°, 180°] that resolve port from starboard, for
arrays whose elements sit off the array axis (twin lines, triplets; thesis 2.2.4.1).

A horizontal plane wave from relative bearing β (clockwise from the forward axis, starboard
positive) has steering vector a(β) (the ``cbf`` one, a_n = e^{j2πfτ_n}, full 3-D positions);
its mirror −β differs only through the cross-axis (y) offsets:

    ρ(β, f) = a(−β)^H a(β) / N = (1/N) Σ_n exp(j 2k y_n sin β),   k = 2πf/c.

For a twin line (y = ±d/2) ρ = cos(kd sin β); for triplets of radius r (hydrophones at
``TRIPLET_ANGLES_DEG``) ρ = (1 + 2 cos(√3 k r sin β))/3; |ρ| → 1 as the cross-axis aperture
kd → 0. Weights (``weights``):

- ``"das"``: delay-and-sum, w = a: the mirror's response is |ρ|² of the look's (signal only);
- ``"cardioid"``: the minimum-norm weights with unit response at β and a null at −β,

      w = (a(β) − γ ρ a(−β)) / (N (1 − γ|ρ|²)),      γ = 1,

  the array-level form of the per-station cardioid of a triplet (Groen et al. 2005): white-noise
  gain N(1 − |ρ|²), so the mirror of a source at per-element SNR s in white noise stands
  10 log10(1 + N(1 − |ρ|²) s) dB below it. Near end-fire (|ρ| → 1) the full null would
  amplify the noise without bound, so ``wng_loss_db`` (default 10 dB) caps the loss of
  white-noise gain against delay-and-sum (WNG floor G = N / 10^(loss/10)): where N(1 − |ρ|²)
  < G, γ < 1 is the deepest null whose WNG N(1 − γ|ρ|²)²/(1 − 2γ|ρ|² + γ²|ρ|²) still reaches
  G (then the mirror's signal response is |ρ|(1 − γ)/(1 − γ|ρ|²) of the look's). The beams
  at exact end-fire (β = 0°, 180°: the mirror is the look direction) keep delay-and-sum
  weights, so their noise level sits up to ``wng_loss_db`` below their neighbours';
- ``"adaptive"``: MVDR over the whole array on these beams (``mvdr`` keys ``snapshots``,
  ``loading``, ``wng_db``): the adaptive port/starboard beamformer of Groen et al. (2005),
  which places its null on the real source when steered at its mirror.

Output: ``das`` / ``cardioid``: beams blocks ``("snapshot", "freq", "beam")`` complex64 as
``cbf`` (scaled by N, so a plane wave from β has the CBF level N²|s|²); ``adaptive``: power
blocks as ``mvdr``. The beam axis is the relative bearing (deg), ``meta.beam_mode = "lr"``:
``integrate``, ``btr`` (column ``cone_deg`` then holds relative bearings) and ``bearings``
(which writes the resolved side, see there) follow.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator

import numpy as np

from arrayproc.chain import Param, Stage, positive, register
from arrayproc.chain.block import Block
from arrayproc.chain.domains import Domain
from arrayproc.errors import ConfigError
from arrayproc.geo.beams import beam_count
from arrayproc.stages.beamform._common import SpectraFramer
from arrayproc.stages.beamform._covstage import COMMON
from arrayproc.stages.beamform.cbf import element_delays
from arrayproc.stages.beamform.mvdr import MVDR


def relative_bearings(beams: dict) -> np.ndarray:
    """Relative bearings (deg) of a ``{start, stop, count}`` table, each in (−180, 180]."""
    try:
        a, b, n = float(beams["start"]), float(beams["stop"]), beam_count(beams["count"])
    except (KeyError, TypeError, ValueError):
        raise ConfigError("key 'beams': expected {start, stop, count} relative bearings "
                          "(deg)") from None
    if set(beams) - {"start", "stop", "count"} or n < 2 or not (
            -180 < a <= 180 and -180 < b <= 180 and a < b):
        raise ConfigError("key 'beams': expected {start, stop, count} with -180 < start < "
                          "stop <= 180 deg and count >= 2")
    return np.linspace(a, b, n)


def mirror_correlation(positions: np.ndarray, rel_deg: np.ndarray, freqs: np.ndarray,
                       sound_speed: float) -> np.ndarray:
    """ρ(β, f) = a(−β)^H a(β) / N (F, B) complex (module doc)."""
    y = np.asarray(positions, float)[:, 1]
    y = y - y.mean()
    k = 2 * np.pi * np.asarray(freqs, float) / sound_speed
    s = np.sin(np.deg2rad(rel_deg))
    return np.exp(2j * k[:, None, None] * s[None, :, None] * y[None, None, :]).mean(axis=2)


def null_depth(rho2: np.ndarray, n: int, wng_db: float | None) -> np.ndarray:
    """γ ∈ [0, 1] of the cardioid weights (module doc): 1, or where the WNG at γ = 1 falls
    short of ``wng_db``, the root of N(1 − γq)² = G(1 − 2γq + γ²q) (q = |ρ|²) in [0, 1]."""
    gamma = np.ones_like(rho2)
    if wng_db is None:
        return gamma
    g = 10 ** (wng_db / 10)
    q = np.clip(rho2, 0.0, 1.0 - 1e-15)
    short = n * (1 - q) < g
    a = n * q * q - g * q
    b = -2 * q * (n - g)
    c = np.full_like(q, n - g)
    disc = np.sqrt(np.maximum(b * b - 4 * a * c, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        r1 = (-b - disc) / (2 * a)
        r2 = (-b + disc) / (2 * a)
    cand = np.where((r1 >= 0) & (r1 <= 1), r1, np.where((r2 >= 0) & (r2 <= 1), r2, 0.0))
    gamma[short] = cand[short]
    return gamma


def lr_weights(positions: np.ndarray, rel_deg: np.ndarray, freqs: np.ndarray,
               sound_speed: float, kind: str, wng_db: float | None = None) -> np.ndarray:
    """Weights (F, C, B) complex128, scaled by N (w^H a(β) = N): delay-and-sum or cardioid
    (module doc). Beams at end-fire (ρ = 1: β and −β coincide) keep the delay-and-sum
    weights."""
    p = np.asarray(positions, float)
    n = p.shape[0]
    dirs = np.stack([np.cos(np.deg2rad(rel_deg)), np.sin(np.deg2rad(rel_deg)),
                     np.zeros(rel_deg.size)], 1)
    tau = element_delays(p, dirs, "3d", sound_speed)  # (B, C)
    tau_m = element_delays(p, dirs * [1.0, -1.0, 0.0], "3d", sound_speed)
    f = np.asarray(freqs, float)[:, None, None]
    a = np.exp(2j * np.pi * f * tau.T[None])  # (F, C, B)
    if kind == "das":
        return a
    am = np.exp(2j * np.pi * f * tau_m.T[None])
    rho = np.einsum("fcb,fcb->fb", am.conj(), a) / n
    q = np.abs(rho) ** 2
    gamma = null_depth(q, n, wng_db)
    gamma[q > 1 - 1e-9] = 0.0  # end-fire: the mirror is the look direction itself
    w = (a - (gamma * rho)[:, None, :] * am) / (1 - gamma * q)[:, None, :]
    return w


@register
class LRCBF(Stage):
    """Port/starboard-resolving beams over relative bearing; see module doc."""

    kind = "lr_cbf"
    accepts = frozenset({Domain.TIME, Domain.SPECTRA})
    produces = Domain.BEAMS
    params = {
        **{k: COMMON[k] for k in ("nfft", "hop", "window", "band", "snapshots", "threads")},
        "beams": Param("table", {"start": -179.0, "stop": 180.0, "count": 360},
                       "relative bearings {start, stop, count}, deg in (-180, 180]", unit="deg"),
        "weights": Param("str", "cardioid", "das (delay-and-sum), cardioid (unit response at β, "
                         "null at −β) or adaptive (MVDR on these beams)",
                         choices=("das", "cardioid", "adaptive")),
        "wng_loss_db": Param("float", 10.0, "cardioid: largest loss of white-noise gain "
                             "against delay-and-sum, dB (the null is made shallower beyond)",
                             check=lambda v: None if v >= 0 else f"must be >= 0, got {v}",
                             unit="dB"),
        "wng_db": Param("float", None, "adaptive: white-noise-gain floor, dB (as mvdr)", unit="dB"),
        "loading": Param("float", 0.01, "adaptive: diagonal loading re the mean element power",
                         check=lambda v: None if v >= 0 else f"must be >= 0, got {v}"),
        "batch": Param("int", 32, "snapshots per output block (das, cardioid)", check=positive),
    }

    def validate(self) -> None:
        if self.hop == 0:
            self.hop = max(1, self.nfft // 2)
        if self.hop < 0:
            raise ConfigError(f"stage {self.name!r}: key 'hop' must be > 0, got {self.hop}")
        try:
            self.beam_axis = relative_bearings(self.beams)
        except ConfigError as e:
            raise ConfigError(f"stage {self.name!r}: {e}") from None
        self._mvdr = None
        if self.weights == "adaptive":
            opt = {k: getattr(self, k) for k in ("band", "wng_db") if getattr(self, k) is not None}
            self._mvdr = MVDR(self.name, nfft=self.nfft, hop=self.hop, window=self.window,
                              snapshots=self.snapshots, loading=self.loading,
                              threads=self.threads, **opt,
                              beams={"bearings": [float(v) for v in self.beam_axis]})
        self._key = None

    def output_domain(self, input_domain: Domain) -> Domain:
        return Domain.POWER if self.weights == "adaptive" else Domain.BEAMS

    def _check_geometry(self, positions: np.ndarray) -> None:
        if np.ptp(np.asarray(positions, float)[:, 1]) < 1e-6:
            raise ConfigError(f"stage {self.name!r}: needs elements off the array axis (a twin "
                              "or triplet array): a line along x cannot tell port from "
                              "starboard")

    def process(self, blocks: Iterator[Block]) -> Iterator[Block]:
        if self._mvdr is not None:
            yield from self._adaptive(blocks)
            return
        rec = self.ctx.recording
        framer = SpectraFramer(self.nfft, self.hop, self.window,
                               None if self.band is None else tuple(self.band),
                               rec.nav if rec is not None else None)
        for b in blocks:
            if b.domain is Domain.TIME:
                if np.iscomplexobj(b.data):
                    raise ConfigError(f"stage {self.name!r}: needs a real time series")
                spec = framer.push(b)
                if spec is None:
                    continue
            else:
                spec = b
            key = (spec.positions.tobytes(), spec.freqs.tobytes(), self.ctx.sound_speed)
            if key != self._key:
                self._check_geometry(spec.positions)
                self._key = key
                floor = 10 * np.log10(spec.positions.shape[0]) - self.wng_loss_db
                w = lr_weights(spec.positions, self.beam_axis, spec.freqs,
                               self.ctx.sound_speed, self.weights, floor)
                self._w = np.ascontiguousarray(w.conj().astype(np.complex64))  # (F, C, B)
            for i in range(0, spec.data.shape[0], self.batch):
                yield self._beams(spec, slice(i, i + self.batch))

    def _beams(self, spec: Block, rows: slice) -> Block:
        """Y = w^H x for the snapshots ``rows`` of a spectra block: one batched GEMM per bin
        (F, S, C) @ (F, C, B)."""
        x = np.ascontiguousarray(spec.data[rows].transpose(1, 0, 2))  # (F, S, C)
        y = np.ascontiguousarray((x @ self._w).transpose(1, 0, 2))  # (S, F, B)
        m = spec.meta

        def sl(v: np.ndarray | None) -> np.ndarray | None:
            return None if v is None else np.asarray(v)[rows]

        meta = dataclasses.replace(m, times=sl(m.times), headings=sl(m.headings),
                                   starts=sl(m.starts), positions_xy=sl(m.positions_xy),
                                   speeds=sl(m.speeds), beam_mode="lr")
        st = meta.starts
        t0 = float(st[0]) / spec.fs if st is not None else spec.t0
        span = (float(st[-1] - st[0]) + m.nfft) / spec.fs if st is not None else spec.span
        return spec.replace(data=y, domain=Domain.BEAMS, beams=self.beam_axis, t0=t0,
                            span=span, meta=meta)

    def _adaptive(self, blocks: Iterator[Block]) -> Iterator[Block]:
        self._mvdr.ctx = self.ctx
        self._mvdr.fs_in = self.fs_in

        def checked(bs: Iterator[Block]) -> Iterator[Block]:
            for b in bs:
                if self._key is None:
                    self._check_geometry(b.positions)
                    self._key = True
                yield b

        for b in self._mvdr.process(checked(blocks)):
            yield b.replace(beams=self.beam_axis,
                            meta=dataclasses.replace(b.meta, beam_mode="lr"))

    def segment_grid(self, fs: float, n_channels: int) -> int:
        """Segment reads on the adaptive covariance groups' grid, or on the frames' hop."""
        if self._mvdr is not None:
            return self._mvdr.segment_grid(fs, n_channels)
        return int(self.hop)

    def warmup_seconds(self, fs: float) -> float:
        if self._mvdr is not None:
            return self._mvdr.warmup_seconds(fs)
        return self.nfft / fs

    def snapshot_seconds(self) -> float | None:
        if self._mvdr is not None:
            self._mvdr.fs_in = self.fs_in
            return self._mvdr.snapshot_seconds()
        return self.hop / self.fs_in if self.fs_in else None
