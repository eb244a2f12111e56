"""``localise``: positions of events from their delays → products ``positions``.

Reads the delays blocks of a ``tde`` stage. For a volumetric array the maximum-likelihood TDOA
position (:func:`.localise.localise_event`: ``scipy.optimize.least_squares`` from several
starts, covariance (Jᵀ J)⁻¹ = (Hᵀ C⁻¹ H)⁻¹ optionally scaled by the fit, thesis eq. (C.8)),
delays below ``min_corr`` rejected, events with fewer than ``min_pairs`` usable delays or a
solution on the search box not localised. Products ``positions`` (docs/formats.md): ``time``,
``x``, ``y``, ``z`` (m, world frame x east, y north, z down), ``cov`` (n, 3, 3) m²,
``tdoa_rms_s``, ``n_used`` (and ``source``, the source index of the delays row, when the
``tde`` stage keeps several peaks: each source of a snapshot is localised on its own, its
covariance the inverse Fisher information of its own delays' σ).

Planar and line arrays cannot fix a 3-D position: the stage falls back to the far-field
direction (:func:`.localise.solve_direction`) and writes a group ``<name>_directions`` with
``time``, ``bearing_deg`` (clockwise from north, ``atan2(u_x, u_y)``), ``elevation_deg``
(above horizontal; for a horizontal planar array its sign is unknown, reported ≥ 0), ``n_used``.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from arrayproc.chain import Param, Stage, register
from arrayproc.chain.block import Block
from arrayproc.errors import ConfigError

from ._common import DELAYS
from .localise import COV_SCALES, LocaliseConfig, array_rank, localise_event, solve_direction


@register
class Localise(Stage):
    """TDOA localisation of events (see the module docstring)."""

    kind = "localise"
    accepts = frozenset({DELAYS})
    params = {
        "min_corr": Param("float", 0.3, "smallest normalised correlation of a usable delay"),
        "min_pairs": Param("int", 4, "fewest usable delays of a localised event"),
        "cov_scale": Param("str", "none", "none, fit (χ²/dof) or inflate (max(1, χ²/dof))",
                           choices=COV_SCALES),
        "max_range": Param("float", 100.0, "half-size of the search box around the array, m",
                           unit="m"),
        "sigma_floor": Param("float", 0.0, "added in quadrature to every delay σ, s", unit="s"),
    }

    def check_input(self, domain) -> None:
        if domain != DELAYS:
            got = getattr(domain, "value", domain)
            raise ConfigError(f"stage {self.name!r} (type 'localise') needs the delays blocks "
                              f"of a 'tde' stage, but its input yields {got} blocks")

    def validate(self) -> None:
        if self.min_pairs < 3:
            raise ConfigError(f"stage {self.name!r}: key 'min_pairs': must be >= 3")
        if not self.max_range > 0:
            raise ConfigError(f"stage {self.name!r}: key 'max_range': must be > 0")

    def process(self, blocks: Iterator[Block]) -> Iterator[Block]:
        cfg = LocaliseConfig(self.min_corr, self.min_pairs, self.cov_scale, self.max_range,
                             self.sigma_floor)
        out = dirs = None
        n_in = n_loc = 0
        for b in blocks:
            m = b.meta
            n_in += 1
            el = np.asarray(m.elements, float)
            if array_rank(el) == 3:
                sol = localise_event(b.data, m.sigma, m.corr, el, m.reference, m.sound_speed,
                                     cfg)
                if sol is not None:
                    n_loc += 1
                    out = out or self.products("positions")
                    if out is not None:
                        p = sol.position
                        extra = {} if m.source < 0 else {"source": np.array([m.source])}
                        out.append(time=np.array([m.time]), x=p[:1], y=p[1:2], z=p[2:3],
                                   cov=sol.cov[None], tdoa_rms_s=np.array([sol.tdoa_rms_s]),
                                   n_used=np.array([sol.n_used]), **extra)
            else:
                got = solve_direction(b.data, m.sigma, m.corr, el, m.reference, m.sound_speed,
                                      self.min_corr)
                if got is not None:
                    n_loc += 1
                    u, _, n_used = got
                    if dirs is None and self.ctx.products is not None:
                        dirs = self.ctx.products.group(f"{self.name}_directions", "directions",
                                                       self.name)
                    if dirs is not None:
                        dirs.append(time=np.array([m.time]),
                                    bearing_deg=np.array([np.degrees(np.arctan2(u[0], u[1]))
                                                          % 360.0]),
                                    elevation_deg=np.array([np.degrees(np.arcsin(
                                        np.clip(-u[2], -1, 1)))]),
                                    n_used=np.array([n_used]))
            yield b
        self.ctx.log(f"{self.name}: {n_loc} of {n_in} events localised")
