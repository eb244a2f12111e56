"""``mvdr``: minimum-variance distortionless-response (Capon) beamformer in the frequency
domain, with diagonal loading fixed or set by a white-noise-gain constraint.

Per bin f and covariance group (the mean of ``snapshots`` snapshot outer products, see
:mod:`_covariance`) the weights that pass a plane wave from θ undistorted and minimise the
output power are (Capon 1969)

    w(θ) = R_δ⁻¹ a(θ) / (a(θ)^H R_δ⁻¹ a(θ)),      R_δ = R̂ + δ I,

with a(θ) the steering vector of ``cbf`` (so the beams point where the CBF beams point). The
stage writes, scaled by N² (N elements) so that a plane wave alone has the level it has in
``cbf`` (``power = "capon"``)

    P(θ) = N² / (a^H R_δ⁻¹ a)                                   (Capon estimate)

or (``power = "output"``) the output power of the loaded beam itself, N² w^H R̂ w, which is
exact for any loading (with δ → ∞ it tends to the CBF power), where the Capon estimate of
the loaded covariance is biased up: N²/a^H R_δ⁻¹ a = N(σ² + δ) for white noise of power σ²,
a factor 1 + ε (+0.04 dB at the default ε = 0.01).

Loading (Carlson 1988; Cox, Zeskind & Owen 1987):

- ``loading`` = ε: fixed δ = ε · tr(R̂)/N, relative to the mean element power of the bin;
- ``wng_db`` = G (dB, at most 10 log10 N): per beam the smallest δ ≥ ε tr(R̂)/N whose
  weights have white-noise gain |w^H a|²/‖w‖² ≥ G (robustness to element position and
  phase errors); needs an eigendecomposition of R̂ per bin and the projections of every
  steering vector on the eigenvectors (F·N²·B work; several times slower than fixed loading).

``forward_backward = true`` averages R̂ with J R̂* J (centro-symmetric arrays, e.g. uniform line
arrays; Pillai 1989): twice the effective snapshots, and coherent pairs decorrelated.

Implementation: one batched inverse per group (numpy's gufunc over the bins, bins split over
the worker threads), then the Hermitian forms a^H R_δ⁻¹ a of every beam through the co-array
lags for line arrays (:mod:`_steering`), batched GEMMs otherwise. A sample covariance of
fewer snapshots than elements is singular: unloaded MVDR is refused then.
"""

from __future__ import annotations

import numpy as np

from arrayproc.chain import Param, register
from arrayproc.errors import ConfigError
from arrayproc.stages.beamform import _adaptive_kernels as ka
from arrayproc.stages.beamform._covariance import exchange, forward_backward, load_diagonal
from arrayproc.stages.beamform._covstage import COMMON, CovarianceStage


def _nonneg(v: float) -> str | None:
    return None if v >= 0 else f"must be >= 0, got {v}"


@register
class MVDR(CovarianceStage):
    """MVDR (Capon) beamformer with robust loading; see module doc."""

    kind = "mvdr"
    params = {
        **COMMON,
        "loading": Param("float", 0.01, "diagonal loading ε: δ = ε·tr(R)/N, relative to the "
                         "mean element power", check=_nonneg),
        "wng_db": Param("float", None, "white-noise-gain floor, dB (<= 10 log10 N): loading "
                        "raised per beam until reached", unit="dB"),
        "forward_backward": Param("bool", False, "forward-backward averaging "
                                  "(centro-symmetric arrays)"),
        "power": Param("str", "capon", "capon (N²/a^H R_δ⁻¹ a) or output (the loaded "
                       "beam's output power N² w^H R w)", choices=("capon", "output")),
    }

    def prepare(self, positions: np.ndarray, freqs: np.ndarray) -> None:
        super().prepare(positions, freqs)
        n = positions.shape[0]
        w = f"stage {self.name!r}"
        self._perm = None
        if self.forward_backward:
            self._perm = exchange(positions)
            if self._perm is None:
                raise ConfigError(f"{w}: key 'forward_backward' needs a centro-symmetric array "
                                  "(e.g. a uniform line array)")
        k_eff = self.snapshots * (2 if self.forward_backward else 1)
        if self.loading == 0 and self.wng_db is None and k_eff < n:
            raise ConfigError(f"{w}: {self.snapshots} snapshots for {n} elements give a "
                              "singular covariance: set key 'loading' > 0 or 'snapshots' >= "
                              f"{-(-n // (2 if self.forward_backward else 1))}")
        if self.wng_db is not None:
            top = 10 * np.log10(n)
            if self.wng_db > top + 1e-9:
                raise ConfigError(f"{w}: key 'wng_db' {self.wng_db:g} dB exceeds the largest "
                                  f"white-noise gain of {n} elements, {top:.2f} dB")
        self._n = n

    def spectrum(self, r: np.ndarray, bins: slice) -> np.ndarray:
        if self._perm is not None:
            r = forward_backward(r, self._perm)
        n = self._n
        sigma = np.real(np.trace(r, axis1=-2, axis2=-1)) / n
        delta = self.loading * sigma  # (f,)
        if self.wng_db is not None:
            return n * n * self._wng_power(r, delta, bins)[0]
        q1 = np.linalg.inv(load_diagonal(r, self.loading))
        f1 = self.steering_form(q1, bins)
        if self.power == "capon" or self.loading == 0:
            return n * n / np.maximum(f1, 1e-300)
        # N² w^H R w = N² a^H Q R Q a / (a^H Q a)² (Q = (R + δI)⁻¹), with Q R Q formed as
        # the product: the identity Q R Q = Q − δQ² cancels catastrophically when δ ≫ λ(R)
        # (relative error ~ u·δ/λ_min, 3e-9 at δ = 1e7·tr R/N)
        q2 = q1 @ (r @ q1)
        return n * n * self.steering_form(q2, bins) / np.maximum(f1, 1e-300) ** 2

    def steering_form(self, q: np.ndarray, bins: slice) -> np.ndarray:
        """a^H Q a (f, B) on the bins ``bins`` of the stream."""
        return self.steering.sub(bins).form(q)

    def _wng_power(self, r: np.ndarray, delta0: np.ndarray,
                   bins: slice) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(power / N², loading δ, WNG linear), each (f, B), under the WNG constraint
        (:func:`_adaptive_kernels.wng_loading`)."""
        lam, u = np.linalg.eigh(r)
        lam = np.maximum(lam, 0.0)
        p = self.steering.sub(bins).projections(u)
        nf, nb = p.shape[:2]
        power, delta, wng = (np.empty((nf, nb)) for _ in range(3))
        ka.wng_loading(np.ascontiguousarray(lam), np.ascontiguousarray(p), delta0,
                       10 ** (self.wng_db / 10), self.power == "output", power, delta, wng)
        return power, delta, wng
