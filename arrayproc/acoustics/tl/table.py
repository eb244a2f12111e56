"""Transmission-loss table TL(range, source depth, receiver depth) with linear interpolation.

SPL paper section 3.2: the propagation model gives TL on a finite grid of ranges and depths
and values in between are linearly interpolated (eq. (13)). A :class:`TLTable` holds TL (dB)
on a regular grid of ranges and receiver depths for one or more source depths; a query is
bilinear in (receiver depth, range) and linear between source depths. Outside the depth grids
and below the first range the edge values are held; beyond the last range TL continues by
cylindrical spreading, TL(r_max) + 10 log10(r / r_max), so that a tracker's hypotheses far
outside the table are not given a constant, too-small loss.

Tables are stored as HDF5 (``data/tl/*.h5``): datasets ``range_m`` (n_r,), ``rcv_depth_m``
(n_z,), ``src_depth_m`` (n_s,), ``tl_db`` (n_s, n_z, n_r), root attrs ``model``, ``freq_hz``,
``description`` and the model's settings.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

from arrayproc.errors import FormatError

__all__ = ["TLTable", "default_table_path", "load_default_table"]

def default_table_path(name: str = "munk_bellhopcxx_incoherent") -> Path:
    """Path of a bundled table in the package data's ``tl`` folder."""
    from arrayproc.data import data_path
    return data_path("tl", f"{name}.h5")


def _axis_index(grid: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Left index and fraction for linear interpolation on a sorted grid (clamped)."""
    if grid.size == 1:
        return np.zeros(x.shape, dtype=np.intp), np.zeros(x.shape)
    xc = np.clip(x, grid[0], grid[-1])
    i = np.clip(np.searchsorted(grid, xc, side="right") - 1, 0, grid.size - 2)
    f = (xc - grid[i]) / (grid[i + 1] - grid[i])
    return i, f


@dataclass
class TLTable:
    """TL (dB) on a grid; ``tl_db`` has shape (n_src_depths, n_rcv_depths, n_ranges)."""

    range_m: np.ndarray
    rcv_depth_m: np.ndarray
    src_depth_m: np.ndarray
    tl_db: np.ndarray
    attrs: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.range_m = np.asarray(self.range_m, dtype=float)
        self.rcv_depth_m = np.asarray(self.rcv_depth_m, dtype=float)
        self.src_depth_m = np.asarray(self.src_depth_m, dtype=float)
        self.tl_db = np.asarray(self.tl_db, dtype=float)
        shape = (self.src_depth_m.size, self.rcv_depth_m.size, self.range_m.size)
        if self.tl_db.shape != shape:
            raise FormatError(f"TL table: tl_db has shape {self.tl_db.shape}, expected {shape}")
        for name in ("range_m", "rcv_depth_m", "src_depth_m"):
            if np.any(np.diff(getattr(self, name)) <= 0):
                raise FormatError(f"TL table: {name} must be strictly increasing")

    def __call__(self, range_m, src_depth_m, rcv_depth_m) -> np.ndarray:
        """TL (dB) at the given range(s), source depth(s) and receiver depth(s) (broadcast);
        bilinear in (receiver depth, range), linear in source depth (SPL paper section 3.2)."""
        r, zs, zr = np.broadcast_arrays(np.asarray(range_m, float), np.asarray(src_depth_m, float),
                                        np.asarray(rcv_depth_m, float))
        i_s, f_s = _axis_index(self.src_depth_m, zs)
        i_z, f_z = _axis_index(self.rcv_depth_m, zr)
        i_r, f_r = _axis_index(self.range_m, r)
        ns, nz, nr = self.tl_db.shape
        rmax = self.range_m[-1]
        out = np.where(r > rmax, 10.0 * np.log10(np.maximum(r, rmax) / rmax), 0.0)
        for ds, ws in ((0, 1.0 - f_s), (1, f_s)):
            js = np.minimum(i_s + ds, ns - 1)
            for dz, wz in ((0, 1.0 - f_z), (1, f_z)):
                jz = np.minimum(i_z + dz, nz - 1)
                for dr, wr in ((0, 1.0 - f_r), (1, f_r)):
                    jr = np.minimum(i_r + dr, nr - 1)
                    out += ws * wz * wr * self.tl_db[js, jz, jr]
        return out

    def range_profile(self, src_depth_m: float, rcv_depth_m: float) -> tuple[float, float,
                                                                             np.ndarray]:
        """TL along range at fixed depths on the table's range grid: ``(r0, dr, tl)``.

        The range grid must be uniform; linear interpolation of this profile in range equals the
        table's bilinear interpolation at these depths (used by the particle-filter kernels).
        """
        d = np.diff(self.range_m)
        if not np.allclose(d, d[0], rtol=1e-6, atol=1e-6):
            raise FormatError("TL table: range_profile needs a uniform range grid")
        tl = self(self.range_m, src_depth_m, rcv_depth_m)
        return float(self.range_m[0]), float(d[0]), np.ascontiguousarray(tl)

    def save(self, path: str | Path) -> None:
        """Write the table as HDF5 (0.01 dB quantisation, compressed)."""
        with h5py.File(path, "w") as f:
            f["range_m"] = self.range_m
            f["rcv_depth_m"] = self.rcv_depth_m
            f["src_depth_m"] = self.src_depth_m
            f.create_dataset("tl_db", data=self.tl_db.astype(np.float32), scaleoffset=2,
                             compression="gzip", compression_opts=9, shuffle=True,
                             chunks=self.tl_db.shape)
            for k, v in self.attrs.items():
                f.attrs[k] = v

    @classmethod
    def load(cls, path: str | Path) -> TLTable:
        """Read a table written by :meth:`save`."""
        try:
            with h5py.File(path, "r") as f:
                return cls(f["range_m"][()], f["rcv_depth_m"][()], f["src_depth_m"][()],
                           f["tl_db"][()].astype(float), dict(f.attrs))
        except (OSError, KeyError) as e:
            raise FormatError(f"{path}: not a TL table ({e})") from None


def load_default_table(name: str = "munk_bellhopcxx_incoherent") -> TLTable:
    """The bundled TL table ``data/tl/<name>.h5`` (the SPL paper's appendix environment)."""
    return TLTable.load(default_table_path(name))
