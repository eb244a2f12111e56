"""Products files as NetCDF4 or Zarr: one group per products group, CF-style attributes.

Each products group is written as the ``xarray.Dataset`` of
:func:`arrayproc.io.labelled.group_dataset` (named dimensions, coordinates, ``units`` and
``long_name`` on every variable, the group's attributes), through xarray's own writers
(``h5netcdf`` for NetCDF4, ``zarr`` in Zarr format 2 with consolidated metadata); the root
group holds the products file's attributes
(``source``, ``chain``, ``units``, ``format`` …) and a ``groups`` attribute listing the groups
in file order. Text columns (``waveform``, ``method``) are written as strings, flags
(``moving``) as xarray encodes booleans. Read back with ``xarray.open_dataset(OUT,
group=NAME)`` (``engine="zarr"`` for Zarr): every variable equals the column
:func:`arrayproc.io.products.read_products` reads (tests/io/test_array_exports.py).

The output is built under a temporary name beside the target and renamed when complete
(:mod:`arrayproc.io.atomic`): a Zarr store is a directory, renamed the same way.
"""

from __future__ import annotations

import logging
import os
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from arrayproc.errors import FormatError
from arrayproc.io.atomic import check_stop, commit, discard, temporary_sibling
from arrayproc.io.h5 import open_h5
from arrayproc.io.labelled import check_products_file, group_dataset, products_attrs
from arrayproc.io.schema import KINDS
from arrayproc.io.text import as_text

FORMATS = ("netcdf", "zarr")
#: Zarr format 2: what every Zarr implementation reads, with consolidated metadata (which
#: format 3 does not specify yet).
ZARR_FORMAT = 2
_log = logging.getLogger(__name__)


def _encodable(ds: Any) -> Any:
    """Text (fixed-length bytes or unicode: the ``waveform`` column, the state labels) as
    variable-length strings, which NetCDF4 and Zarr v3 both specify."""
    for name, v in list(ds.variables.items()):
        if v.dtype.kind == "S":
            ds[name] = v.copy(data=np.char.decode(np.asarray(v.values), "utf-8", "replace")
                              .astype(object))
        elif v.dtype.kind == "U":
            ds[name] = v.copy(data=np.asarray(v.values).astype(object))
    return ds


def _groups(f: h5py.File) -> list[str]:
    return [n for n, g in f.items() if isinstance(g, h5py.Group)
            and as_text(g.attrs.get("kind", "")) in KINDS]


def _in_process() -> Any:
    """Compute lazy columns in this process's threads, whatever scheduler a caller made the
    default (a ``distributed.Client`` sets one): the source file is open here only."""
    import dask
    return dask.config.set(scheduler="threads")


def _write(f: h5py.File, tmp: Path, to: str) -> int:
    with _in_process():
        return _write_groups(f, tmp, to)


def _write_groups(f: h5py.File, tmp: Path, to: str) -> int:
    import xarray as xr
    names = _groups(f)
    root = xr.Dataset(attrs={**products_attrs(f), "groups": names,
                             "history": "written by arrayproc export from "
                                        f"{os.path.basename(f.filename)}"})
    if to == "netcdf":
        root.to_netcdf(tmp, mode="w", engine="h5netcdf")
    else:
        root.to_zarr(tmp, mode="w", consolidated=False, zarr_format=ZARR_FORMAT)
    for name in names:
        check_stop()
        ds = _encodable(group_dataset(f, name, lazy=None))
        _log.debug(f"{to}: group {name} ({ds.attrs.get('kind', '')}): "
                   f"{dict(ds.sizes)}")
        if to == "netcdf":
            ds.to_netcdf(tmp, mode="a", group=name, engine="h5netcdf")
        else:
            ds.to_zarr(tmp, mode="a", group=name, consolidated=False, zarr_format=ZARR_FORMAT)
    if to == "zarr":  # one metadata read for readers (xarray tries it first)
        import zarr
        zarr.consolidate_metadata(str(tmp), zarr_format=ZARR_FORMAT)
    return len(names)


def _remove(p: Path) -> None:
    discard(p)  # a file or a store's directory


def write_arrays(products: str | os.PathLike, output: str | os.PathLike, to: str) -> int:
    """Write a products file as NetCDF4 (``to="netcdf"``) or Zarr (``"zarr"``), atomically.

    Parameters
    ----------
    products : str or path-like
        Products (or tracks) file.
    output : str or path-like
        NetCDF file or Zarr store (a directory) to write; an existing one is replaced.
    to : {"netcdf", "zarr"}

    Returns
    -------
    int
        Groups written.
    """
    if to not in FORMATS:
        raise FormatError(f"export: arrays format must be netcdf or zarr, not {to!r}")
    out = Path(output)
    if to == "zarr" and out.exists() and not (out.is_dir() and _is_zarr(out)):
        raise FormatError(f"{out}: exists and is not a Zarr store; give a new path")
    with open_h5(products, "products file") as f:
        check_products_file(f, products)
        tmp = temporary_sibling(out)
        try:
            n = _write(f, tmp, to)
            check_stop()
            if to == "zarr" and out.exists():
                old = temporary_sibling(out)
                os.replace(out, old)
                commit(tmp, out)
                _remove(old)
            else:
                commit(tmp, out)
        except BaseException:
            _remove(tmp)
            raise
    return n


def _is_zarr(p: Path) -> bool:
    return (p / "zarr.json").is_file() or (p / ".zgroup").is_file()
