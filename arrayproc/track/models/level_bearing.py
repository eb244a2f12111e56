"""Bearing and received level, SPL paper (Iglésis & de Montella 2024) eqs. (9), (12), (15)-(16),
(31)-(33).

z = [θ, l]: the bearing γ(X) = atan2(x, y) with noise σθ, and the received level
l = SL(v) − TL(r) + υ, υ ~ N(0, σ_l²), dB re 1 µPa, where SL(v) = sl0 + slope·log10(v / v_ref)
is the source level at the target's absolute speed v (eq. (12),
:class:`arrayproc.acoustics.source_level.SourceLevelModel`) and TL(r) the transmission loss at
the horizontal range r for the source and receiver depths, from a TL table
(:mod:`arrayproc.acoustics.tl`), linear in range and continued by cylindrical spreading beyond
the table. The two noises are independent, so log p(z | X) is the sum of eqs. (32) and (33).
"""

from __future__ import annotations

import math

import numpy as np

from arrayproc.acoustics.source_level import SourceLevelModel
from arrayproc.errors import ConfigError
from arrayproc.track.base import Param
from arrayproc.track.models import _kernels as km
from arrayproc.track.models.base import MeasurementModel
from arrayproc.track.state import Context

__all__ = ["LevelBearing"]


def _positive(v: float) -> str | None:
    return None if v > 0 else "must be > 0"


class LevelBearing(MeasurementModel):
    """[bearing (rad), level (dB re 1 µPa)] of a relative state; see the module docstring.

    ``tl_table``: a :class:`~arrayproc.acoustics.tl.table.TLTable`, the name of a bundled
    table, or a path to a table file. ``source_level`` = (sl0 dB re 1 µPa @ 1 m, slope dB per
    decade, v_ref m/s).
    """

    name = "level_bearing"
    state_rows = 4
    angular = (True, False)
    params = {
        "sigma_deg": Param("float", 1.5, "bearing noise σθ, deg", check=_positive),
        "sigma_level_db": Param("float", 10.0, "level noise σ_l, dB", check=_positive),
        "tl_table": Param("any", "munk_bellhopcxx_incoherent", "TL table (name, path or "
                          "TLTable)"),
        "src_depth_m": Param("float", 5.0, "source depth, m"),
        "rcv_depth_m": Param("float", 300.0, "receiver depth, m"),
        "source_level": Param("floats", [170.0, 53.0, 5.14], "(sl0, slope, v_ref) of eq. (12)",
                              check=lambda v: None if len(v) == 3 and v[2] > 0 else
                              "must be [sl0_db, slope_db, v_ref_mps] with v_ref > 0"),
    }

    def _setup(self) -> None:
        from arrayproc.acoustics.tl.table import TLTable, default_table_path

        t = self.tl_table
        if isinstance(t, str):
            path = t if ("/" in t or t.endswith(".h5")) else default_table_path(t)
            t = TLTable.load(path)  # FormatError naming the file if it is not a table
        elif not isinstance(t, TLTable):
            raise ConfigError(f"{self.name}.tl_table: expected a table name, path or TLTable")
        r0, dr, tl = t.range_profile(self.src_depth_m, self.rcv_depth_m)
        self.profile = (float(r0), float(dr), np.ascontiguousarray(tl, dtype=float))
        self.sl = SourceLevelModel(*self.source_level)
        self.sl_par = self.sl.as_array()
        self.sigma = math.radians(self.sigma_deg)
        self._R = np.diag([self.sigma ** 2, self.sigma_level_db ** 2])

    def function_points(self, X, ctx, out) -> None:
        r0, dr, tl = self.profile
        km.level_bearing_points(X, ctx.own, self.sl_par, r0, dr, tl, out)

    def jacobian(self, x: np.ndarray, ctx: Context) -> np.ndarray:
        H = np.empty((2, np.size(x)))
        r0, dr, tl = self.profile
        km.level_bearing_jacobian(np.ascontiguousarray(x, dtype=float), ctx.own, self.sl_par,
                                  r0, dr, tl, H)
        return H

    def covariance(self, ctx: Context | None = None) -> np.ndarray:
        return self._R

    def loglik_particles(self, rel, z, ctx, out) -> None:
        z = np.asarray(z, float).reshape(2)
        r0, dr, tl = self.profile
        km.level_bearing_loglik(rel, ctx.own, z[0], z[1], self.sigma, self.sigma_level_db,
                                self.sl_par, r0, dr, tl, out)

    def loglik_norm(self, ctx: Context | None = None) -> float:
        return (math.log(math.sqrt(2 * math.pi) * self.sigma)
                + math.log(math.sqrt(2 * math.pi) * self.sigma_level_db))
