"""Image sources of a flat iso-velocity waveguide: pressure-release surface (z = 0), lossy
flat bottom (z = D), the ``[propagation] multipath`` table of a scenario.

A source at depth z_s has images at depths 2mD + z_s and 2mD − z_s (m integer). The image
z' = 2mD + s·z_s (s = ±1) stands for a path with

    s = +1:  n_surface = n_bottom = |m|;
    s = −1:  m ≥ 1: n_bottom = m, n_surface = m − 1;   m ≤ 0: n_surface = |m| + 1, n_bottom = |m|,

independently of the receiver depth, and its coherent reflection coefficient is

    R = (−1)^{n_surface} · 10^{−n_bottom·BL/20} · exp(−Γ²/2)^{n_surface},   Γ = 2kσ sin θ,

(Rayleigh roughness of the surface, k = 2πf/c at ``roughness_freq``, σ the RMS height, θ the
grazing angle of the unfolded straight path, the same at every bounce). The received pressure of
a path is R·s(t − τ)/(cτ) with τ the image's exact retarded time, so every path has its own
delay, spreading and Doppler. The two-path case (surface only) is Lloyd's mirror,
p ∝ e^{ikr₁}/r₁ − e^{ikr₂}/r₂.

The images are a short closed-form enumeration; no library offers them for a moving source in
the time domain, hence this module.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from arrayproc.sim.scenario import MultipathSpec


@dataclass(frozen=True)
class Image:
    """One image path: depth map z ↦ a + s·z, reflection counts and the smooth coefficient."""

    a: float
    s: float
    n_surface: int
    n_bottom: int
    coef: float  # (−1)^{n_s} · 10^{−n_b·BL/20} (roughness applied per sample)

    @property
    def order(self) -> int:
        return self.n_surface + self.n_bottom

    def depth(self, z: np.ndarray | float) -> np.ndarray | float:
        """Image depth of a point at depth z."""
        return self.a + self.s * z


DIRECT = Image(0.0, 1.0, 0, 0, 1.0)


def images(spec: MultipathSpec | None) -> list[Image]:
    """Every image path of at most ``spec.order`` reflections, the direct path first.

    Ordered by (order, surface bounces, m) so the list does not depend on depths.
    """
    if spec is None:
        return [DIRECT]
    out = [DIRECT]
    rb = 10 ** (-spec.bottom_loss_db / 20.0)
    big = spec.order + 1
    for m in range(-big, big + 1):
        for s in (1.0, -1.0):
            if m == 0 and s == 1.0:
                continue
            if s > 0:
                ns = nb = abs(m)
            elif m >= 1:
                nb, ns = m, m - 1
            else:
                ns, nb = -m + 1, -m
            if ns + nb > spec.order or (nb and spec.bottom_depth is None):
                continue
            if ns and not spec.surface:
                continue
            d = spec.bottom_depth or 0.0
            out.append(Image(2.0 * m * d, s, ns, nb, (-1.0) ** ns * rb ** nb))
    out[1:] = sorted(out[1:], key=lambda im: (im.order, im.n_surface, im.a, im.s))
    return out


def rough_exponent(spec: MultipathSpec | None, img: Image, c: float) -> float:
    """n_surface·2(kσ)²: the kernels' coherent factor is exp(−this·sin²θ) = exp(−Γ²/2)^n."""
    if spec is None or img.n_surface == 0 or spec.surface_rms_height <= 0:
        return 0.0
    k = 2 * np.pi * spec.roughness_freq / c
    return float(img.n_surface * 2.0 * (k * spec.surface_rms_height) ** 2)


def roughness_factor(spec: MultipathSpec | None, img: Image, sin_grazing: np.ndarray,
                     c: float) -> np.ndarray:
    """exp(−Γ²/2)^{n_surface}, Γ = 2kσ sin θ: the rough surface's coherent amplitude factor."""
    s = np.asarray(sin_grazing, float)
    return np.exp(-rough_exponent(spec, img, c) * s * s)


class ImageMover:
    """A mover's image: z ↦ a + s·z, velocity and acceleration z-components times s."""

    def __init__(self, mover: object, img: Image) -> None:
        self.mover = mover
        self.img = img

    @property
    def is_static(self) -> bool:
        return bool(getattr(self.mover, "is_static", False))

    def state3(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        p, v, a = self.mover.state3(t)
        if self.img is DIRECT:
            return p, v, a
        p, v, a = p.copy(), v.copy(), a.copy()
        p[:, 2] = self.img.a + self.img.s * p[:, 2]
        v[:, 2] *= self.img.s
        a[:, 2] *= self.img.s
        return p, v, a


def path_sin_grazing(src_image_z: np.ndarray, rcv_z: np.ndarray, path_len: np.ndarray
                     ) -> np.ndarray:
    """sin θ of the unfolded straight path from an image at depth z' to a receiver at z."""
    return np.abs(np.asarray(src_image_z) - np.asarray(rcv_z)) / np.maximum(path_len, 1e-9)
