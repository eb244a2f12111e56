"""``music``: MUSIC pseudo-spectrum per bin (Schmidt 1986) on the beam grid, with the number of
sources given or estimated (MDL/AIC), spatial smoothing and forward-backward averaging for
coherent sources, and root-MUSIC directions for uniform line arrays.

Per bin f and covariance group (``snapshots`` snapshots, :mod:`_covariance`): the eigenvectors
of R̂ (after forward-backward averaging and/or spatial smoothing over ``smoothing`` subarrays)
split into the signal subspace E_s of the M largest eigenvalues and the noise subspace E_n;

    P(θ) = L / (a^H E_n E_n^H a) = L / (L − a^H E_s E_s^H a)        (Schmidt 1986)

with a(θ) the ``cbf`` steering vector of the L elements used (L = N, or the subarray length
N − smoothing + 1). P is dimensionless, about L/(L − M) away from the sources and large at
them; it is not a power (``bearings`` levels of a ``music`` chain are not sound levels). M is
``sources`` (an integer), or per bin by ``"mdl"`` or ``"aic"`` (Wax & Kailath 1985), capped
by ``max_sources``.

``root = true`` (uniform line arrays, cone beams): the M roots of the noise-subspace polynomial
nearest the unit circle (Barabell 1983) give cone angles off the grid, one row per (group, bin,
root) in products ``doa``: ``time``, ``freq``, ``cone_deg``, ``radius`` (|z| of the root, 1 for
a noiseless source). ``output`` and the blocks are as for ``mvdr`` (:mod:`_covstage`).
"""

from __future__ import annotations

import numpy as np

from arrayproc.chain import Param, positive, register
from arrayproc.chain.block import Block
from arrayproc.errors import ConfigError
from arrayproc.stages.beamform._covariance import exchange, forward_backward, spatial_smoothing
from arrayproc.stages.beamform._covstage import COMMON, CovarianceStage
from arrayproc.stages.beamform._steering import Steering, line_lags
from arrayproc.stages.beamform._subspace import (
    root_music,
    signal_projector,
    source_count,
    top_subspace,
)


def _sources(v: object) -> str | None:
    if v in ("mdl", "aic"):
        return None
    if isinstance(v, bool) or not isinstance(v, int) or v < 1:
        return f"must be a positive integer, 'mdl' or 'aic', got {v!r}"
    return None


@register
class MUSIC(CovarianceStage):
    """MUSIC pseudo-spectrum and root-MUSIC; see module doc."""

    kind = "music"
    params = {
        **COMMON,
        "sources": Param("any", "mdl", "number of sources, or 'mdl' / 'aic' per bin (needs "
                         "snapshots >= elements)",
                         check=_sources),
        "max_sources": Param("int", 8, "cap on the estimated number of sources",
                             check=positive),
        "smoothing": Param("int", 1, "spatial smoothing over this many subarrays (uniform "
                           "line arrays; 1: none)", check=positive),
        "forward_backward": Param("bool", False, "forward-backward averaging "
                                  "(centro-symmetric arrays)"),
        "root": Param("bool", False, "root-MUSIC cone angles into products 'doa' (uniform "
                      "line arrays)"),
    }

    def prepare(self, positions: np.ndarray, freqs: np.ndarray) -> None:
        w = f"stage {self.name!r}"
        p = np.asarray(positions, float)
        n = p.shape[0]
        self._perm = exchange(p) if self.forward_backward else None
        if self.forward_backward and self._perm is None:
            raise ConfigError(f"{w}: key 'forward_backward' needs a centro-symmetric array")
        lags = line_lags(p, self.beam_mode == "cone")
        full_line = lags is not None and np.array_equal(np.sort(lags[0]), np.arange(n))
        if (self.smoothing > 1 or self.root) and not full_line:
            raise ConfigError(f"{w}: keys 'smoothing' and 'root' need a uniform line array "
                              "(elements at every multiple of one spacing)")
        if self.root and self.beam_mode != "cone":
            raise ConfigError(f"{w}: key 'root' gives cone angles: use cone beams "
                              "(beams = {start, stop, count})")
        self._order = np.argsort(lags[0], kind="stable") if full_line else np.arange(n)
        size = n - self.smoothing + 1
        if size < 2:
            raise ConfigError(f"{w}: key 'smoothing' {self.smoothing} leaves fewer than 2 of "
                              f"{n} elements")
        sub = p[self._order[:size]]
        self.steering = Steering(sub, self._dirs, self.beam_mode, freqs, self.ctx.sound_speed)
        self._size = size
        self._spacing = lags[1] if lags is not None else np.nan
        cap = size - 1
        if isinstance(self.sources, int) and self.sources > cap:
            raise ConfigError(f"{w}: key 'sources' {self.sources} leaves no noise subspace of "
                              f"{size} elements")
        k_eff = self.snapshots * self.smoothing * (2 if self.forward_backward else 1)
        if self.sources in ("mdl", "aic") and k_eff < size:
            raise ConfigError(f"{w}: key 'sources' = {self.sources!r} needs at least as many "
                              f"snapshots as elements ({k_eff} < {size}): raise 'snapshots' "
                              "or give the number of sources")
        self._freqs = np.asarray(freqs, float)
        self._roots: dict[int, tuple] = {}

    def _subspace(self, r: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(eigenvalues ascending (f, K), eigenvectors (f, L, K), source count (f,)): the M
        leading pairs only (K = M, block orthogonal iteration) for a given number of sources,
        every pair (numpy's eigh) when it is estimated."""
        if self._perm is not None:
            r = forward_backward(r, self._perm)
        if self.smoothing > 1:
            r = spatial_smoothing(r, self._order, self.smoothing)
        else:
            r = r[..., self._order[:, None], self._order[None, :]]
        if isinstance(self.sources, int):
            lam, u = top_subspace(r, self.sources)
            return lam[:, ::-1], u[:, :, ::-1], np.full(lam.shape[0], self.sources)
        lam, u = np.linalg.eigh(r)
        count = source_count(lam, self.snapshots, self.sources)
        count = np.clip(count, 0, min(self.max_sources, self._size - 1))
        return lam, u, count

    def spectrum(self, r: np.ndarray, bins: slice) -> np.ndarray:
        lam, u, count = self._subspace(r)
        ps = signal_projector(u, lam, count)
        size = self._size
        den = size - self.steering.sub(bins).form(ps)
        if self.root:
            qn = np.eye(size)[None] - ps
            psi, rad = root_music(qn, count)
            self._roots[bins.start] = (psi, rad)
        return size / np.maximum(den, 1e-12 * size)

    def process(self, blocks):
        out = None
        for b in super().process(blocks):
            if self.root:
                out = out if out is not None else self.products("doa")
                self._write_roots(out, b)
            yield b

    def _write_roots(self, out, b: Block) -> None:
        """Rows of products ``doa`` for one group: ψ = 2πf d cos θ / c (lags ascending in x,
        so the phase grows towards the forward end as in :mod:`_steering`)."""
        parts = [self._roots[k] for k in sorted(self._roots)]
        self._roots = {}
        if out is None or not parts:
            return
        m = max(p[0].shape[1] for p in parts)
        psi = np.concatenate([np.pad(p[0], ((0, 0), (0, m - p[0].shape[1])),
                                     constant_values=np.nan) for p in parts])
        rad = np.concatenate([np.pad(p[1], ((0, 0), (0, m - p[1].shape[1])),
                                     constant_values=np.nan) for p in parts])
        f = np.repeat(self._freqs[:, None], m, 1)
        u = psi * self.ctx.sound_speed / (2 * np.pi * f * self._spacing)
        ok = np.isfinite(u) & (np.abs(u) <= 1.0) & (f > 0)
        if not ok.any():
            return
        out.append(time=np.full(int(ok.sum()), float(b.meta.times[0])), freq=f[ok],
                   cone_deg=np.rad2deg(np.arccos(u[ok])), radius=rad[ok])
