"""``ibf``: inverse beamforming, the coherent "onion peeler" (thesis 2.2.3.3, after Wilson and
Nuttall).

Per snapshot: beamform the element spectra over the band, take the loudest direction, refine
it, estimate the plane wave's amplitude and phase in every bin by least squares on the element
spectra (jointly with the waves found before), subtract the synthetic plane wave from every
element, and repeat — up to ``max_sources`` waves, or until the loudest remaining beam is less
than ``stop_db`` above the noise estimate. Removing a wave at the elements removes its
sidelobes too.

Output: the cleaned element spectra (domain ``("snapshot", "freq", "channel")``, see
:mod:`arrayproc.stages.beamform._common`) for ``etam``/``psas`` downstream, and a products group
``ibf_removed`` with one row per removed wave and snapshot: ``time`` (s), ``cone_deg``,
``level_db`` (the wave's in-band mean square at an element, dB re 1 µPa² for data in Pa,
re FS² for data in full scale),
``snr_db`` (band beam power over the noise estimate), ``freq_lo``, ``freq_hi`` (Hz).
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from arrayproc.chain import Param, Stage, positive, register
from arrayproc.chain.block import Block
from arrayproc.chain.domains import Domain
from arrayproc.dsp import fft
from arrayproc.errors import ConfigError
from arrayproc.io.units import recording_units, reference_amplitude
from arrayproc.stages.beamform import _sa_kernels as ks
from arrayproc.stages.beamform._common import element_spectra, line_geometry, rule_snapshot_seconds


def plane_wave(freqs: np.ndarray, x: np.ndarray, u: np.ndarray, c: float) -> np.ndarray:
    """Plane-wave signature at the elements: exp(+j 2π f x_n u / c), shape (F, C).

    ``u`` (F,) is the cosine of the cone angle per bin, ``x`` (C,) the elements' body x (m).
    """
    return np.exp(2j * np.pi * (freqs * u / c)[:, None] * x[None, :])


def joint_fit(X: np.ndarray, freqs: np.ndarray, x: np.ndarray, u: np.ndarray, c: float,
              iters: int = 4, max_step: float = 0.25) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares fit of K plane waves over a band: one direction per wave, one complex
    amplitude per wave and bin (variable projection, Gauss-Newton on the directions).

    Minimises Σ_f ||X_f − Σ_j a_{f,j} v_f(u_j)||², v_f(u)_n = exp(+j2π f x_n u / c), for a
    uniform line ``x`` (fore → aft). ``u`` (K,) starting direction cosines. Each step solves
    Σ_f Re(J_fᴴJ_f) Δu = −Σ_f Re(J_fᴴ r_f) with ∂r_f/∂u_j = −a_{f,j} (j 2π f x / c) ⊙ v_f(u_j)
    (kernel :func:`~arrayproc.stages.beamform._sa_kernels.plane_wave_fit`), the step limited to
    ``max_step`` beamwidths at the band centre. Returns ``(u, A)`` with A (F, K).
    """
    n_f, n_k = X.shape[0], u.size
    x0, dx = float(x[0]), float(x[0] - x[1]) if x.size > 1 else 1.0
    bw = c / (np.median(freqs) * np.ptp(x) + 1e-12)
    u = np.asarray(u, float).copy()
    A = np.empty((n_f, n_k), np.complex128)
    H = np.empty((n_f, n_k, n_k))
    g = np.empty((n_f, n_k))
    for it in range(iters + 1):
        ks.plane_wave_fit(X, freqs, u, x0, dx, c, A, H, g)
        if it == iters:
            break
        Hs = H.sum(0)
        Hs += 1e-9 * np.trace(Hs) * np.eye(n_k)
        du = -np.linalg.solve(Hs, g.sum(0))
        u = np.clip(u + np.clip(np.nan_to_num(du), -max_step * bw, max_step * bw), -1.0, 1.0)
    return u, A


def onion_peel(X: np.ndarray, freqs: np.ndarray, x: np.ndarray, dx: float, c: float,
               max_sources: int = 3, stop_db: float = 3.0,
               sector: tuple[float, float] | None = None, keep_sources: int = 2,
               oversample: int = 4, grid: int = 0, fit_iters: int = 2,
               detect_bins: int = 512) -> tuple[np.ndarray, list[dict]]:
    """Remove the loudest plane waves of a band from one snapshot's element spectra.

    Each round beamforms the residual over the band (the sum over bins of the beam powers),
    takes the loudest direction, refines it, and re-estimates all modelled waves jointly
    (:func:`joint_fit`: one direction per wave, an amplitude and phase per bin). Waves inside
    ``sector`` (up to ``max_sources``) are removed from the elements; other waves found on the
    way (up to ``keep_sources``, e.g. a target outside the sector) stay in the data but take
    part in the joint estimate, so their leakage does not bias the removed waves and they
    lose nothing.

    Parameters
    ----------
    X : (F, C) complex
        Element spectra, elements ordered fore → aft (body x = ``x``, uniform spacing ``dx``).
    freqs : (F,) Hz.  c : sound speed, m/s.
    max_sources : waves removed at most.
    stop_db : stop when the loudest remaining band beam power is less than ``stop_db`` above
        the noise estimate (the median band beam power over the visible directions).
    sector : (lo, hi) cone angles (deg) of the waves to remove, or None for all.
    keep_sources : waves kept in the joint model but not removed, at most.
    oversample, grid : each bin is scanned by a zero-padded spatial FFT of ``oversample``·C
        points (at least 256) and the powers interpolated onto ``grid`` directions uniform in
        cos θ (default 4·C + 1) before summing over the band.
    detect_bins : directions are detected and fitted on at most this many bins spread evenly
        over the band (plenty for a band-wide direction); the amplitudes are then solved in
        every bin.

    Returns
    -------
    residual : (F, C) complex64, the spectra with the removed waves subtracted.
    removed : one dict per removed wave: ``cone_deg``, ``amp`` (F,) complex amplitudes at the
        elements, ``snr_db`` (band beam power over the noise estimate).
    """
    X_all, freqs_all = np.asarray(X, np.complex128), np.asarray(freqs, float)
    stride = max(1, -(-X_all.shape[0] // max(1, detect_bins)))
    X, freqs = np.ascontiguousarray(X_all[::stride]), np.ascontiguousarray(freqs_all[::stride])
    n_f, n_c = X.shape
    n_pad = max(256, int(2 ** np.ceil(np.log2(oversample * n_c))))
    n_g = grid or 4 * n_c + 1
    ug = np.linspace(-1.0, 1.0, n_g)
    fpos = np.maximum(freqs, 1e-12)
    # Cell index (fractional) of each grid direction in each bin's scan: k = u n_pad f δx / c.
    kf = ug[None, :] * (n_pad * fpos * dx / c)[:, None]
    k0 = np.floor(kf).astype(np.int64)
    w1 = kf - k0
    u_lo, u_hi = (-1.0, 1.0) if sector is None else (np.cos(np.deg2rad(sector[1])),
                                                     np.cos(np.deg2rad(sector[0])))
    bw = c / (np.median(fpos) * n_c * dx)  # beamwidth in u at the band centre

    bgrid = np.empty(n_g)

    def band_power(R: np.ndarray) -> np.ndarray:
        # Σ_n R_n exp(+j2π n k / n_pad) = n_pad · ifft (single precision is plenty here)
        y = fft.ifft(R.astype(np.complex64), n=n_pad, axis=1)
        p = (y.real**2 + y.imag**2).astype(np.float64) * (n_pad**2 / n_c)
        ks.band_power_on_grid(p, k0, w1, bgrid)
        return bgrid.copy()

    us: list[float] = []
    remove: list[bool] = []
    snrs: list[float] = []
    A = np.zeros((n_f, 0), np.complex128)
    R = X
    n_removed = n_kept = 0
    for _ in range(max_sources + keep_sources):
        B = band_power(R)
        noise = float(np.median(B))
        allowed = np.ones(n_g, bool)
        for uj in us:
            allowed &= np.abs(ug - uj) > 0.5 * bw
        if n_kept >= keep_sources:  # only removable waves may still be taken
            if n_removed >= max_sources:
                break
            allowed &= (ug >= u_lo) & (ug <= u_hi)
        if not allowed.any():
            break
        g = int(np.argmax(np.where(allowed, B, -np.inf)))
        if not B[g] > noise * 10 ** (stop_db / 10.0):
            break
        # Start from a parabola through the grid cells around the peak; joint_fit refines.
        u = ug[g]
        if 0 < g < n_g - 1:
            den = B[g - 1] - 2 * B[g] + B[g + 1]
            if den < 0:
                u += float(np.clip(0.5 * (B[g - 1] - B[g + 1]) / den, -0.5, 0.5)) * (ug[1] - ug[0])
        inside = u_lo - 1e-12 <= u <= u_hi + 1e-12
        is_removed = inside and n_removed < max_sources
        n_removed += is_removed
        n_kept += not is_removed
        us.append(u)
        remove.append(is_removed)
        snrs.append(float(10 * np.log10(B[g] / noise)))
        u_fit, A = joint_fit(X, freqs, x, np.array(us), c, iters=fit_iters)
        us = list(u_fit)
        R = np.empty_like(X)
        ks.subtract_plane_waves(X, freqs, u_fit, A, float(x[0]), dx, c, R)
    if not any(remove):
        return X_all.astype(np.complex64), []
    rm = np.array(remove)
    u_all = np.array(us)
    # amplitudes in every bin at the fitted directions, and the removal
    A = np.empty((freqs_all.size, u_all.size), np.complex128)
    out = np.empty_like(X_all)
    ks.remove_plane_waves(X_all, freqs_all, u_all, rm, float(x[0]), dx, c, out, A)
    removed = [{"cone_deg": float(np.rad2deg(np.arccos(us[j]))), "amp": A[:, j],
                "snr_db": snrs[j]} for j in np.flatnonzero(rm)]
    return out.astype(np.complex64), removed


@register
class IBF(Stage):
    """Inverse beamforming, the coherent onion peeler (thesis 2.2.3.3); see module doc."""

    kind = "ibf"
    accepts = frozenset({Domain.TIME, Domain.SPECTRA})
    produces = Domain.SPECTRA
    params = {
        "max_sources": Param("int", 3, "plane waves removed per bin at most", check=positive),
        "stop_db": Param("float", 3.0, "stop when the loudest beam is less than this above the "
                         "noise estimate (median band beam power over directions), dB", unit="dB"),
        "sector": Param("band", None, "[lo, hi] cone angles (deg) to peel (default: all)",
                        unit="deg"),
        "keep_sources": Param("int", 2, "waves outside the sector (or beyond max_sources) kept "
                              "in the joint estimate but not removed, per bin"),
        "snapshot": Param("str", "etam", "snapshot length when framing time data: from the nav "
                          "speed by the 'etam' (T_B = (N_H−1)δx/2U, eq. 2.52) or 'psas' (T_B = "
                          "N_H δx/U, eq. 2.32) rule, rounded up to an FFT-friendly length, or "
                          "'nfft'",
                          choices=("etam", "psas", "nfft")),
        "nfft": Param("int", 0, "samples per snapshot when snapshot = 'nfft'", unit="samples"),
        "window": Param("str", "none", "time taper", choices=("none", "hann", "hamming")),
        "band": Param("band", None, "[lo, hi] Hz (default: all bins)", unit="Hz"),
        "record": Param("bool", True, "write the removed waves (products ibf_removed)"),
    }

    def validate(self) -> None:
        if self.snapshot == "nfft" and self.nfft <= 0:
            raise ConfigError(f"stage {self.name!r}: key 'nfft' must be > 0 when snapshot = "
                              "'nfft'")
        if self.sector is not None and not (0 <= self.sector[0] and self.sector[1] <= 180):
            raise ConfigError(f"stage {self.name!r}: key 'sector' must lie in [0, 180] deg")

    def snapshot_seconds(self) -> float | None:
        return rule_snapshot_seconds(self)

    def process(self, blocks: Iterator[Block]) -> Iterator[Block]:
        out = self.products("ibf_removed") if self.record else None
        for spec in element_spectra(self, blocks):
            yield self.peel(spec, out)

    def peel(self, spec: Block, out=None) -> Block:
        order, dx = line_geometry(self.name, spec.positions)
        x = spec.positions[order, 0] - spec.positions[:, 0].mean()
        c = self.ctx.sound_speed
        data = spec.data.copy()
        rows: dict[str, list[float]] = {k: [] for k in ("time", "cone_deg", "level_db", "snr_db",
                                                        "freq_lo", "freq_hi")}
        nfft = spec.meta.nfft
        ref = reference_amplitude(recording_units(self.ctx.recording))
        for s in range(data.shape[0]):
            res, removed = onion_peel(spec.data[s][:, order], spec.freqs, x, dx, c,
                                      self.max_sources, self.stop_db,
                                      None if self.sector is None else tuple(self.sector),
                                      self.keep_sources)
            data[s][:, order] = res
            for r in removed:
                # In-band mean square of the wave at an element (Parseval, one-sided).
                ms = 2.0 * float(np.sum(np.abs(r["amp"]) ** 2)) / nfft**2
                rows["time"].append(float(spec.meta.times[s]))
                rows["cone_deg"].append(r["cone_deg"])
                rows["level_db"].append(10 * np.log10(max(ms, 1e-300) / ref**2))
                rows["snr_db"].append(r["snr_db"])
                rows["freq_lo"].append(float(spec.freqs[0]))
                rows["freq_hi"].append(float(spec.freqs[-1]))
        if out is not None:
            out.append(**{k: np.asarray(v, float) for k, v in rows.items()})
        return spec.replace(data=data)


