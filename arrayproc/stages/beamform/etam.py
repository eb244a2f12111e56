"""``psas`` and ``etam``: passive synthetic aperture by coherent integration of snapshots
(thesis 2.1.2.2, 2.2.3.1).

Both form beams on each snapshot's physical aperture first (sub-aperture beamforming, thesis
p. 2.1.2.2 "a faster implementation"), then combine the last ``snapshots`` sub-aperture beams
coherently in a sliding window, steering each by its along-track displacement D_s:

    Y(θ, f) = Σ_s B_s(θ, f) · exp(j Φ_s(f)) · exp(−j 2π f D_s cos θ / c)      (2.33)-(2.35)

They differ in the inter-snapshot phase Φ_s:

- ``psas`` (ideal): the known time offset of each snapshot, Φ_s = −2π f (t_s − t_1) — term (3)
  of eq. (2.31). Exact for a stationary field and a rigid, straight-moving array.
- ``etam`` (overlap correlator of Stergiopoulos and Sullivan): Φ_s accumulates the phase
  corrections Ψ_b(f) measured between the elements that successive snapshots share, weighted
  by their coherence over ``q_bins`` bins (eqs. 2.53-2.54), which also absorbs unknown phase
  perturbations (lateral motion, source motion) of the dominant source in each bin.

Snapshot length: from the nav speed U, T_B = N_H δx / U for ``psas`` (eq. 2.32: the apertures
abut) and T_B = (N_H − 1) δx / (2U) for ``etam`` (eq. 2.52: they half overlap), or given as
``nfft``. Input: time blocks, or element spectra from ``ibf`` (then their framing is used).
Output: blocks of domain ``("snapshot", "freq", "beam")`` like the ``cbf`` stage's, one per
input snapshot once the window is full, so ``integrate``, ``btr``, ``lofar`` and ``bearings``
work unchanged (thesis fig. 2.9: coherent then incoherent integration).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterator

import numpy as np

from arrayproc.chain import Param, Stage, positive, register
from arrayproc.chain.block import Block
from arrayproc.chain.domains import Domain, SnapshotMeta, Synthetic
from arrayproc.errors import ConfigError
from arrayproc.geo.beams import cone_axis
from arrayproc.stages.beamform import _sa_kernels as ks
from arrayproc.stages.beamform._common import element_spectra, line_geometry, rule_snapshot_seconds


class _SyntheticAperture(Stage):
    """Sliding-window coherent combination of sub-aperture beams (shared by psas and etam)."""

    accepts = frozenset({Domain.TIME, Domain.SPECTRA})
    produces = Domain.BEAMS

    rule = ""
    params = {
        "snapshots": Param("int", 10, "N_S, snapshots combined coherently", check=positive),
        "snapshot": Param("str", "", "snapshot length rule when framing time data: 'psas', "
                          "'etam' or 'nfft' (default: the stage's own rule)",
                          choices=("", "psas", "etam", "nfft")),
        "nfft": Param("int", 0, "samples per snapshot when snapshot = 'nfft'", unit="samples"),
        "window": Param("str", "none", "time taper", choices=("none", "hann", "hamming")),
        "band": Param("band", None, "[lo, hi] Hz (default: all bins)", unit="Hz"),
        "beams": Param("table", {"start": 0.0, "stop": 180.0, "count": 181},
                       "cone angles {start, stop, count}, deg", unit="deg"),
    }

    def validate(self) -> None:
        if not self.snapshot:
            self.snapshot = self.rule
        if self.snapshot == "nfft" and self.nfft <= 0:
            raise ConfigError(f"stage {self.name!r}: key 'nfft' must be > 0 when snapshot = "
                              "'nfft'")
        try:
            self.cone = cone_axis(self.beams)
        except ConfigError as e:
            raise ConfigError(f"stage {self.name!r}: {e}") from None
        self._u = np.cos(np.deg2rad(self.cone))

    def snapshot_seconds(self) -> float | None:
        return rule_snapshot_seconds(self)

    def warmup_seconds(self, fs: float) -> float:
        """N_S snapshots (the window) before the segment's first output."""
        dt = self.snapshot_seconds()
        return 0.0 if dt is None else self.snapshots * dt

    # Φ_s for the newest snapshot given the previous one; overridden by ETAM.
    def phase_step(self, prev: dict, cur: dict, freqs: np.ndarray) -> np.ndarray:
        return -2.0 * np.pi * freqs * (cur["t0"] - prev["t0"])

    def process(self, blocks: Iterator[Block]) -> Iterator[Block]:
        window: deque[dict] = deque(maxlen=self.snapshots)
        ring: np.ndarray | None = None  # (N_S, B, F) sub-aperture beams, reused
        slot = 0
        index = 0
        for spec in element_spectra(self, blocks):
            order, dx = line_geometry(self.name, spec.positions)
            xb = spec.positions[order, 0]
            x0 = xb[0] - spec.positions[:, 0].mean()
            c = self.ctx.sound_speed
            freqs = np.asarray(spec.freqs, np.float64)
            for s in range(spec.data.shape[0]):
                x = np.ascontiguousarray(spec.data[s][:, order])
                sub = np.empty((freqs.size, self._u.size), np.complex64)
                ks.subaperture_beams(x, freqs, self._u, float(x0), float(dx), float(c), sub)
                if ring is None or ring.shape[2] != freqs.size:
                    ring = np.empty((self.snapshots, self._u.size, freqs.size), np.complex64)
                    slot = 0
                ring[slot] = sub.T  # beam-major for the combination kernel
                m = spec.meta
                hd = float(m.headings[s])
                cur = {"x": x, "slot": slot, "t": float(m.times[s]),
                       "t0": float(m.starts[s]) / spec.fs,
                       "pos": np.asarray(m.positions_xy[s], float),
                       "heading": hd, "dx": dx}
                if window:
                    prev = window[-1]
                    cur["phi"] = prev["phi"] + self.phase_step(prev, cur, freqs)
                else:
                    cur["phi"] = np.zeros(freqs.size)
                window.append(cur)
                slot = (slot + 1) % self.snapshots
                if len(window) < self.snapshots:
                    continue
                y = self.combine(ring, window, freqs, c)
                times = np.array([window[-1]["t"]])
                yield Block(y[None], Domain.BEAMS, window[0]["t0"],
                            window[-1]["t0"] - window[0]["t0"] + m.nfft / spec.fs,
                            spec.fs, spec.positions, spec.pose, spec.freqs, self.cone, index,
                            SnapshotMeta(times, np.array([hd]), m.nfft, m.hop, m.window, m.df,
                                         starts=np.array([m.starts[s]]),
                                         synthetic=Synthetic(self.snapshots, self.kind,
                                                             window[0]["t"])))
                index += 1

    def combine(self, ring: np.ndarray, window: deque, freqs: np.ndarray,
                c: float) -> np.ndarray:
        """Synthetic beams (F, B) of the snapshots in ``window`` (eqs. 2.33-2.35)."""
        first = window[0]
        h = np.deg2rad(first["heading"])
        fwd = np.array([np.sin(h), np.cos(h)])
        order = np.array([w["slot"] for w in window], np.int64)
        phase = np.exp(1j * np.stack([w["phi"] - first["phi"] for w in window]))
        disp = np.array([float((w["pos"] - first["pos"]) @ fwd) for w in window])
        out = np.empty((freqs.size, self._u.size), np.complex64)
        ks.combine_subapertures(ring, order, phase, disp, freqs, self._u, float(c), out)
        return out


@register
class PSAS(_SyntheticAperture):
    """Ideal passive synthetic aperture (thesis eqs. 2.33-2.35); see module doc."""

    kind = "psas"
    rule = "psas"
    params = dict(_SyntheticAperture.params)


@register
class ETAM(_SyntheticAperture):
    """ETAM overlap correlator (thesis eqs. 2.52-2.54); see module doc."""

    kind = "etam"
    rule = "etam"
    params = dict(_SyntheticAperture.params)
    params["q_bins"] = Param("int", 5, "Q, bins over which the pair coherence ρ is measured "
                             "(eq. 2.54)", check=positive)

    def phase_step(self, prev: dict, cur: dict, freqs: np.ndarray) -> np.ndarray:
        """Ψ_b(f) of eq. (2.53) from the elements both snapshots share."""
        h = np.deg2rad(prev["heading"])
        moved = float((cur["pos"] - prev["pos"]) @ np.array([np.sin(h), np.cos(h)]))
        # Half-integer shifts are the rule, not the exception: eq. (2.52) moves the array by
        # (N_H − 1)/2 elements. Round halves up (N_H/2, as the thesis pairs them), with a
        # tolerance so that nav rounding cannot flip the choice between snapshots.
        shift = int(np.floor(moved / cur["dx"] + 0.5 + 1e-6))
        n_c = cur["x"].shape[1]
        if not 0 < shift < n_c:
            if not getattr(self, "_warned", False):
                self.ctx.log(f"stage {self.name!r}: successive snapshots share no elements "
                             f"(moved {moved:.2f} m); falling back to the ideal phase")
                self._warned = True
            return super().phase_step(prev, cur, freqs)
        psi = np.empty(freqs.size)
        ks.etam_phase(prev["x"], cur["x"], shift, self.q_bins, psi)
        return psi


def etam_reference(spectra: list[np.ndarray], freqs: np.ndarray, x: np.ndarray,
                   disp_step: float, shift: int, n_s: int, cone: np.ndarray, c: float,
                   q: int = 5) -> list[np.ndarray]:
    """Plain-numpy ETAM (eqs. 2.33-2.35 and 2.53-2.54) for tests and benchmarks.

    ``spectra``: (F, C) element spectra of successive snapshots (elements fore → aft,
    body x = ``x``), the array moving ``disp_step`` m (``shift`` elements) per snapshot.
    Returns the synthetic beams (F, B) of every full window of ``n_s`` snapshots.
    """
    u = np.cos(np.deg2rad(cone))
    xc = x - x.mean()
    n_c = xc.size
    kern = np.ones(q)

    def smooth(v: np.ndarray) -> np.ndarray:  # sum over the q bins centred on each bin
        return np.apply_along_axis(lambda col: np.convolve(col, kern, "same"), 0, v)
    outs: list[np.ndarray] = []
    beams: list[np.ndarray] = []
    phis: list[np.ndarray] = []
    prev = None
    for X in spectra:
        sub = np.empty((freqs.size, u.size), complex)
        for a in range(0, freqs.size, 256):  # steering matrices in slabs of bins
            f = freqs[a:a + 256]
            steer = np.exp(-2j * np.pi * f[:, None, None] * xc[None, None, :] * u[None, :, None]
                           / c)
            sub[a:a + 256] = np.einsum("fbc,fc->fb", steer, X[a:a + 256])
        if prev is None:
            phi = np.zeros(freqs.size)
        else:
            a_, b_ = prev[:, : n_c - shift], X[:, shift:]
            prod = a_ * b_.conj()
            rho = np.abs(smooth(prod)) / np.sqrt(smooth(np.abs(a_) ** 2)
                                                 * smooth(np.abs(b_) ** 2))
            phi = phis[-1] + np.angle((rho * prod).sum(1))
        prev = X
        beams.append(sub)
        phis.append(phi)
        if len(beams) >= n_s:
            p0 = phis[-n_s]
            outs.append(sum(b * np.exp(1j * (p - p0))[:, None]
                            * np.exp(-2j * np.pi * freqs[:, None] * (k * disp_step) * u[None, :]
                                     / c)
                            for k, (b, p) in enumerate(zip(beams[-n_s:], phis[-n_s:]))))
    return outs
