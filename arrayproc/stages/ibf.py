"""``ibf``: inverse beamforming, the coherent "onion peeler" (thesis 2.2.3.3, after Wilson and
Nuttall).

Per snapshot and frequency bin: beamform the element spectra, take the loudest beam, refine its
direction, estimate the plane-wave amplitudes of all waves found so far by least squares on the
element spectra, subtract the synthetic plane waves from every element, and repeat — up to
``max_sources`` waves, or until the loudest remaining beam is less than ``stop_db`` above the
noise estimate. Removing a wave at the elements removes its sidelobes too.

Output: the cleaned element spectra (domain ``("snapshot", "freq", "channel")``, see
:mod:`arrayproc.snapshots`) for ``etam``/``psas`` downstream, and a products group
``ibf_removed`` with one row per removed wave: ``time`` (s), ``cone_deg``, ``freq`` (Hz),
``level_db`` (the wave's level at the elements, dB re 1 µPa rms for a tone centred on the bin,
data in Pa), ``snr_db`` (beam power over the noise estimate).
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from .. import fft
from ..block import Block
from ..chain import Param, Stage, positive, register
from ..errors import ConfigError
from ..snapshots import SPECTRA_DOMAIN, SpectraFramer, snapshot_seconds, uniform_line


def plane_wave(freqs: np.ndarray, x: np.ndarray, u: np.ndarray, c: float) -> np.ndarray:
    """Plane-wave signature at the elements: exp(+j 2π f x_n u / c), shape (F, C).

    ``u`` (F,) is the cosine of the cone angle per bin, ``x`` (C,) the elements' body x (m).
    """
    return np.exp(2j * np.pi * (freqs * u / c)[:, None] * x[None, :])


def joint_fit(X: np.ndarray, freqs: np.ndarray, x: np.ndarray, U: np.ndarray,
              mask: np.ndarray, c: float, iters: int = 4,
              max_step: float = 0.25) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares fit of K plane waves per bin: directions by Gauss-Newton, amplitudes by
    linear least squares (variable projection).

    Minimises ||X − Σ_j a_j v(u_j)||² per bin, v(u)_n = exp(+j2π f x_n u / c). ``U`` (F, K)
    starting direction cosines, ``mask`` (F, K) which waves exist in each bin. Each step solves
    Re(JᴴJ) Δu = −Re(Jᴴ r) with ∂r/∂u_j = −a_j (j 2π f x / c) ⊙ v_j, the step limited to
    ``max_step`` beamwidths. Returns ``(U, A)``.
    """
    k = 2.0 * np.pi * freqs / c  # (F,)
    bw = c / (np.maximum(freqs, 1e-12) * np.ptp(x) + 1e-12)  # beamwidth in u
    U = U.copy()
    eye = np.eye(U.shape[1], dtype=bool)[None]

    def solve_amplitudes(V: np.ndarray) -> np.ndarray:
        G = np.einsum("fck,fcl->fkl", V.conj(), V)
        G[~mask[:, :, None] & eye] = 1.0
        rhs = np.einsum("fck,fc->fk", V.conj(), X)
        A = np.linalg.solve(G, rhs[..., None])[..., 0]
        A[~mask] = 0.0
        return A

    for it in range(iters + 1):
        V = np.exp(1j * (k[:, None, None] * x[None, :, None]) * U[:, None, :])  # (F, C, K)
        V[np.broadcast_to(~mask[:, None, :], V.shape)] = 0.0
        A = solve_amplitudes(V)
        if it == iters:
            break
        r = X - np.einsum("fck,fk->fc", V, A)
        J = -(1j * k[:, None, None] * x[None, :, None]) * V * A[:, None, :]
        H = np.einsum("fck,fcl->fkl", J.conj(), J).real
        H[~mask[:, :, None] & eye] = 1.0
        g = np.einsum("fck,fc->fk", J.conj(), r).real
        with np.errstate(invalid="ignore"):
            du = -np.linalg.solve(H, g[..., None])[..., 0]
        du = np.nan_to_num(du)
        lim = max_step * bw[:, None]
        U = np.where(mask, np.clip(U + np.clip(du, -lim, lim), -1.0, 1.0), U)
    return U, A


def onion_peel(X: np.ndarray, freqs: np.ndarray, x: np.ndarray, dx: float, c: float,
               max_sources: int = 3, stop_db: float = 12.0,
               sector: tuple[float, float] | None = None, keep_sources: int = 2,
               oversample: int = 8, fit_iters: int = 4
               ) -> tuple[np.ndarray, list[dict[str, np.ndarray]]]:
    """Remove the loudest plane waves from one snapshot's element spectra.

    Each round takes the loudest beam of the current residual in every bin, refines its
    direction, adds that plane wave to the bin's model and re-estimates the amplitudes of all
    modelled waves jointly by least squares on the element spectra. Waves inside ``sector``
    (up to ``max_sources`` of them) are removed; other waves found on the way (up to
    ``keep_sources``, e.g. a target outside the sector) stay in the data but take part in the
    joint estimate, so their leakage does not bias the removed waves and they lose nothing.

    Parameters
    ----------
    X : (F, C) complex
        Element spectra, elements ordered fore → aft (body x = ``x``, uniform spacing ``dx``).
    freqs : (F,) Hz.  c : sound speed, m/s.
    max_sources : waves removed per bin at most.
    stop_db : a bin stops when its loudest remaining beam is less than ``stop_db`` above the
        noise estimate (the median beam power of the current residual over the bin's visible
        region divided by ln 2, the median of an exponential law). The loudest of ~C noise
        beams exceeds the mean by ln C + … ≈ 6-10 dB, so keep ``stop_db`` above that.
    sector : (lo, hi) cone angles (deg) of the waves to remove, or None for all.
    keep_sources : waves kept in the joint model but not removed, per bin at most.
    oversample : the beam scan is a zero-padded spatial FFT of ``oversample``·C points (at
        least 256), refined by a parabola through the three cells around the peak.
    fit_iters : Gauss-Newton iterations of the joint direction fit of all modelled waves
        after each round (:func:`joint_fit`).

    Returns
    -------
    residual : (F, C) complex, the spectra with the removed waves subtracted.
    removed : one dict per removed-wave slot with per-bin arrays ``bin`` (indices),
        ``cone_deg``, ``amp`` (complex amplitude at the elements) and ``snr_db``.
    """
    n_f, n_c = X.shape
    n_pad = max(256, int(2 ** np.ceil(np.log2(oversample * n_c))))
    k = np.fft.fftfreq(n_pad) * n_pad  # signed cell index
    # Cell k looks towards u = k c / (n_pad f δx) (aliased beyond |u| = 1: grating lobes).
    fpos = np.maximum(freqs, 1e-12)
    u_of = k[None, :] * c / (n_pad * fpos[:, None] * dx)
    visible = np.abs(u_of) <= 1.0
    u_lo, u_hi = (-1.0, 1.0) if sector is None else (np.cos(np.deg2rad(sector[1])),
                                                     np.cos(np.deg2rad(sector[0])))
    rows = np.arange(n_f)

    def scan(R: np.ndarray) -> np.ndarray:
        # Σ_n R_n exp(+j2π n k / n_pad) = n_pad · ifft: the beam at u_k up to a phase.
        y = fft.ifft(R, n=n_pad, axis=1) * n_pad
        return (y.real**2 + y.imag**2) / n_c  # beam power, E = σ² for white noise

    n_vis = visible.sum(axis=1)
    # Visible cells first in each row, so a row's median is taken over its visible region.
    vis_order = np.argsort(~visible, axis=1, kind="stable")

    def noise_of(P: np.ndarray) -> np.ndarray:
        """Median beam power of each bin's visible region / ln 2 (exponential-law mean)."""
        Ps = np.take_along_axis(P, vis_order, axis=1)
        out = np.full(n_f, np.nan)
        for m in np.unique(n_vis[n_vis > 0]):
            rows_m = n_vis == m
            out[rows_m] = np.median(Ps[rows_m, :m], axis=1) / np.log(2.0)
        return out

    P = scan(X)
    noise = noise_of(P)

    X = X.astype(np.complex128)
    kinds: list[np.ndarray] = []  # (F,) True where that wave is to be removed
    info: list[tuple[np.ndarray, np.ndarray]] = []  # (present, snr_db)
    us: list[np.ndarray] = []  # (F,) direction cosine of each wave
    masks: list[np.ndarray] = []  # (F,) where each wave is modelled
    n_removed = np.zeros(n_f, int)
    n_kept = np.zeros(n_f, int)
    active = np.isfinite(noise)
    A = np.zeros((n_f, 0), np.complex128)
    R = X
    for _ in range(max_sources + keep_sources):
        if not active.any():
            break
        if us:
            P = scan(R)
            # The noise estimate follows the residual: the sidelobes of removed waves no
            # longer inflate it.
            noise = np.fmin(noise, noise_of(P))
        thresh = noise * 10 ** (stop_db / 10.0)
        Pm = np.where(visible, P, -np.inf)
        kk = np.argmax(Pm, axis=1)
        peak = Pm[rows, kk]
        go = active & (peak > thresh)
        if not go.any():
            break
        # Parabolic refinement in the cell index (on the log power, neighbours wrapped).
        with np.errstate(divide="ignore", invalid="ignore"):
            lm = np.log(P[rows, (kk - 1) % n_pad])
            l0 = np.log(np.maximum(peak, 1e-300))
            lp = np.log(P[rows, (kk + 1) % n_pad])
            den = lm - 2 * l0 + lp
            delta = np.where(np.abs(den) > 1e-12, 0.5 * (lm - lp) / den, 0.0)
        delta = np.clip(np.nan_to_num(delta), -0.5, 0.5)
        u = np.clip((k[kk] + delta) * c / (n_pad * fpos * dx), -1.0, 1.0)
        inside = (u >= u_lo - 1e-12) & (u <= u_hi + 1e-12)
        remove = go & inside & (n_removed < max_sources)
        keep = go & ~remove & (n_kept < keep_sources)
        present = remove | keep
        n_removed += remove
        n_kept += keep
        # A bin whose loudest wave is neither removable nor keepable stops here.
        active = active & present
        if not present.any():
            break
        us.append(np.where(present, u, 0.0))
        masks.append(present)
        kinds.append(remove)
        with np.errstate(divide="ignore", invalid="ignore"):
            info.append((present, 10 * np.log10(np.maximum(peak, 1e-300) / noise)))
        Um, Mm = np.stack(us, axis=1), np.stack(masks, axis=1)
        Um, A = joint_fit(X, freqs, x, Um, Mm, c, iters=fit_iters)
        us = list(Um.T)
        V = np.exp(1j * (2 * np.pi * freqs / c)[:, None, None] * x[None, :, None]
                   * Um[:, None, :])
        V[np.broadcast_to(~Mm[:, None, :], V.shape)] = 0.0
        R = X - np.einsum("fck,fk->fc", V, A)
    if not us:
        return X.astype(np.complex64), []
    rm = np.stack(kinds, axis=1)
    out = X - np.einsum("fck,fk->fc", V, np.where(rm, A, 0.0))
    removed = []
    for j, (present, snr) in enumerate(info):
        sel = present & rm[:, j]
        if sel.any():
            removed.append({"bin": np.flatnonzero(sel),
                            "cone_deg": np.rad2deg(np.arccos(us[j][sel])),
                            "amp": A[sel, j], "snr_db": snr[sel]})
    return out.astype(np.complex64), removed


@register
class IBF(Stage):
    """Inverse beamforming, the coherent onion peeler (thesis 2.2.3.3); see module doc."""

    kind = "ibf"
    params = {
        "max_sources": Param("int", 3, "plane waves removed per bin at most", check=positive),
        "stop_db": Param("float", 12.0, "stop when the loudest beam is less than this above the "
                         "noise estimate, dB"),
        "sector": Param("band", None, "[lo, hi] cone angles (deg) to peel (default: all)"),
        "keep_sources": Param("int", 2, "waves outside the sector (or beyond max_sources) kept "
                              "in the joint estimate but not removed, per bin"),
        "snapshot": Param("str", "etam", "snapshot length when framing time data: from the nav "
                          "speed by the 'etam' (eq. 2.52) or 'psas' (eq. 2.32) rule, or 'nfft'",
                          choices=("etam", "psas", "nfft")),
        "nfft": Param("int", 0, "samples per snapshot when snapshot = 'nfft'"),
        "window": Param("str", "none", "time taper", choices=("none", "hann", "hamming")),
        "band": Param("band", None, "[lo, hi] Hz (default: all bins)"),
        "record": Param("bool", True, "write removed waves to the products group"),
    }

    def validate(self) -> None:
        if self.snapshot == "nfft" and self.nfft <= 0:
            raise ConfigError(f"stage {self.name!r}: key 'nfft' must be > 0 when snapshot = "
                              "'nfft'")
        if self.sector is not None and not (0 <= self.sector[0] and self.sector[1] <= 180):
            raise ConfigError(f"stage {self.name!r}: key 'sector' must lie in [0, 180] deg")

    def process(self, blocks: Iterator[Block]) -> Iterator[Block]:
        out = self.products("ibf_removed") if self.record else None
        framer: SpectraFramer | None = None
        for b in blocks:
            if b.domain == ("time", "channel"):
                if framer is None:
                    framer = make_framer(self, b)
                spec = framer.push(b)
                if spec is None:
                    continue
            elif b.domain == SPECTRA_DOMAIN:
                spec = b
            else:
                raise ConfigError(f"stage {self.name!r}: needs time or element-spectra input, "
                                  f"got {b.domain}")
            yield self.peel(spec, out)

    def peel(self, spec: Block, out=None) -> Block:
        order, dx = line_geometry(self.name, spec.positions)
        x = spec.positions[order, 0] - spec.positions[:, 0].mean()
        c = self.ctx.sound_speed
        data = spec.data.copy()
        rows: dict[str, list[np.ndarray]] = {k: [] for k in
                                             ("time", "cone_deg", "freq", "level_db", "snr_db")}
        nfft = spec.meta["nfft"]
        for s in range(data.shape[0]):
            res, removed = onion_peel(spec.data[s][:, order], spec.freqs, x, dx, c,
                                      self.max_sources, self.stop_db,
                                      None if self.sector is None else tuple(self.sector),
                                      self.keep_sources)
            data[s][:, order] = res
            if out is not None:
                for r in removed:
                    n = r["bin"].size
                    rows["time"].append(np.full(n, spec.meta["times"][s]))
                    rows["cone_deg"].append(r["cone_deg"])
                    rows["freq"].append(spec.freqs[r["bin"]])
                    ms = 2.0 * np.abs(r["amp"]) ** 2 / nfft**2  # mean square of a bin tone
                    rows["level_db"].append(10 * np.log10(np.maximum(ms, 1e-300) / 1e-12))
                    rows["snr_db"].append(r["snr_db"])
        if out is not None:
            out.append(**{k: (np.concatenate(v) if v else np.zeros(0)) for k, v in rows.items()})
        return spec.replace(data=data)


def line_geometry(name: str, positions: np.ndarray) -> tuple[np.ndarray, float]:
    """Element order and spacing of a uniform line array, or a ConfigError naming the stage."""
    try:
        return uniform_line(positions)
    except ConfigError as e:
        raise ConfigError(f"stage {name!r}: {e}") from None


def make_framer(stage: Stage, b: Block) -> SpectraFramer:
    """The element-spectra framer of a stage with ``snapshot``/``nfft``/``window``/``band``
    keys: the snapshot length from the nav speed (thesis eq. 2.32 or 2.52) or given."""
    if stage.snapshot == "nfft":
        nfft = stage.nfft
    else:
        _, dx = line_geometry(stage.name, b.positions)
        speed = b.pose.speed if b.pose is not None else 0.0
        try:
            tb = snapshot_seconds(stage.snapshot, b.positions.shape[0], dx, speed)
        except ConfigError as e:
            raise ConfigError(f"stage {stage.name!r}: {e}") from None
        nfft = int(round(tb * b.fs))
    rec = stage.ctx.recording
    nav = rec.nav if rec is not None else None
    return SpectraFramer(nfft, nfft, stage.window,
                         None if stage.band is None else tuple(stage.band), nav)
