"""Products and recordings as labelled arrays: ``xarray.Dataset`` and ``pandas.DataFrame``.

Every products group becomes one ``xarray.Dataset`` (:func:`group_dataset`): its columns are
data variables whose first dimension is the row (``time`` for the kinds ``power``, ``btr``,
``lofar`` and ``delays``, whose rows are snapshots; ``obs``, as CF names the observations of a
table, for every other kind), its trailing dimensions are named by the kind's axes when one
labels them (``cone_deg``, ``freq``, ``range_rate_mps``, ``range_m``) and otherwise by the
schema's ``dims`` (``channel``, ``state_i``/``state_j``, ``axis_i``/``axis_j``). The axes are
coordinates. A beam dimension is ``cone_deg`` for cone beams; for the 3-D and
relative-bearing fans (group attribute ``beam_mode`` ``"3d"`` or ``"lr"``, where ``cone_deg``
holds relative bearings, repeated for each elevation) it is ``beam``, with ``cone_deg`` and
``elevation_deg`` as coordinates on it.
Each variable carries ``units`` and ``long_name`` from :mod:`arrayproc.io.schema`, levels in
the unit of the file's samples (``dB re 1 µPa`` or ``dB re FS``, :mod:`arrayproc.io.units`);
the group's attributes and the file's root attributes (``source``, ``chain``, ``units``, …)
are the dataset's attributes.

:func:`open_products` gives the gridded kinds as Datasets and the tables (bearings, lines,
contacts, tracks, tma, …) as DataFrames, one row per row (a matrix column such as ``cov``
holds one (k, k) array per row). Datasets larger than :data:`LAZY_BYTES` are dask arrays
chunked along the HDF5 chunks, read when computed; the file stays open while they live.
:func:`open_recording` gives ``/time_data`` the same way (gains applied, dead channels
dropped, as :class:`arrayproc.io.recording.Recording` reads it).

Written here rather than opened with xarray's own ``h5netcdf`` engine: products files are
plain HDF5 without dimension scales, so that engine could only invent dimension names from
the sizes; the names come from the schema instead.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import Any

import h5py
import numpy as np

from arrayproc.errors import FormatError
from arrayproc.io.h5 import open_h5
from arrayproc.io.schema import KINDS, Column
from arrayproc.io.text import as_text
from arrayproc.io.units import file_units, level_label

#: Kinds whose rows are snapshots on a time axis (row dimension ``time``); the others are
#: tables (row dimension ``obs``, as CF names the observations of a table).
GRIDDED = ("power", "btr", "lofar", "delays", "range_doppler")
TIME_ROWS = ("power", "btr", "lofar", "delays")
#: A dataset above this size (bytes) is read lazily through dask unless told otherwise.
LAZY_BYTES = 64 << 20
#: Labels of the schema's named trailing dimensions.
DIM_LABELS = {"state_i": ["x", "y", "vx", "vy"], "state_j": ["x", "y", "vx", "vy"],
              "axis_i": ["x", "y", "z"], "axis_j": ["x", "y", "z"]}


def _xr():
    try:
        import xarray
    except ImportError:  # pragma: no cover - the extra is not installed
        raise FormatError("labelled arrays need xarray (pip install 'arrayproc[labelled]')"
                          ) from None
    return xarray


def attr_value(v: Any) -> Any:
    """An HDF5 attribute as a NetCDF-safe value: text for bytes, integers for booleans."""
    if isinstance(v, bytes):
        return v.decode(errors="replace")
    if isinstance(v, (bool, np.bool_)):
        return int(v)
    if isinstance(v, np.ndarray):
        if v.dtype.kind == "b":
            return v.astype(np.int8)
        if v.dtype.kind in "SO":
            return [as_text(x) for x in v.reshape(-1)]
    return v


def _attrs(a: Mapping[str, Any]) -> dict[str, Any]:
    return {str(k): attr_value(v) for k, v in a.items()}


def column_attrs(col: Column, units: str) -> dict[str, str]:
    """``units`` and ``long_name`` of a schema column, levels in the file's sample unit."""
    unit = col.unit
    if unit.startswith("dB re 1 µPa"):
        unit = level_label(units) + unit[len("dB re 1 µPa"):]
    return {"units": unit, "long_name": col.long_name}


def _read(d: h5py.Dataset, lazy: bool | None) -> Any:
    """A dataset as numpy, or as a dask array when ``lazy`` (None: when it is large)."""
    if lazy is None:
        lazy = d.size * d.dtype.itemsize > LAZY_BYTES
    if not lazy or d.ndim == 0:
        return d[()]
    import dask.array as da
    return da.from_array(d, chunks="auto", lock=True)


def _trailing_dims(kind: str, name: str, col: Column, g: Mapping[str, Any],
                   beam_dim: str) -> list[str]:
    dims = []
    for k in range(len(col.trailing)):
        labels = col.labels[k] if k < len(col.labels) else ()
        axis = next((a for a in labels if a in g), None)
        if axis is not None:
            dims.append(beam_dim if axis in ("cone_deg", "bearing_deg") else axis)
        elif k < len(col.dims):
            dims.append(col.dims[k])
        else:
            dims.append(f"{name}_dim{k + 1}")
    return dims


def group_dataset(f: h5py.File, name: str, lazy: bool | None = None) -> Any:
    """One products group of an open products file as an ``xarray.Dataset`` (module doc).

    Parameters
    ----------
    f : h5py.File
        An open products file.
    name : str
        The group.
    lazy : bool, optional
        Read through dask (True), into memory (False), or dask only for datasets larger
        than :data:`LAZY_BYTES` (None).

    Returns
    -------
    xarray.Dataset
    """
    xr = _xr()
    g = f[name]
    kind = as_text(g.attrs.get("kind", ""))
    k = KINDS.get(kind)
    if k is None:
        raise FormatError(f"{f.filename}: group {name!r} has kind {kind!r}, which this "
                          "arrayproc does not know")
    units = file_units(f.attrs)
    mode = as_text(g.attrs.get("beam_mode", "cone")) or "cone"
    beam_dim = "cone_deg" if mode == "cone" and "cone_deg" in g else "beam"
    if mode == "cone" and "cone_deg" not in g and "bearing_deg" in g:
        beam_dim = "bearing_deg"
    row = "time" if kind in TIME_ROWS else "obs"
    data_vars: dict[str, Any] = {}
    coords: dict[str, Any] = {}
    for col_name, d in list(g.items()):  # h5py holds its lock while iterating items()
        if not isinstance(d, h5py.Dataset):
            continue
        col = k.columns.get(col_name) or k.axes.get(col_name)
        if col is None:
            continue  # read_products refuses undeclared names; a newer file's: skipped
        values = _read(d, lazy)
        attrs = column_attrs(col, units)
        if col_name in k.axes:
            dim = beam_dim if col_name in ("cone_deg", "bearing_deg", "elevation_deg") \
                else col_name
            coords[col_name] = ((dim,) if d.ndim == 1 else (dim, f"{col_name}_dim2"),
                                values, attrs)
            continue
        dims = [row, *_trailing_dims(kind, col_name, col, g, beam_dim)][:d.ndim]
        dims += [f"{col_name}_dim{i}" for i in range(len(dims), d.ndim)]
        target = coords if (col_name == "time" and row == "time") else data_vars
        target[col_name] = (tuple(dims), values, attrs)
    for dim, labels in DIM_LABELS.items():
        if any(dim in v[0] for v in data_vars.values()):
            coords.setdefault(dim, ((dim,), labels, {"long_name": "state component"}))
    ds = xr.Dataset(data_vars, coords)
    for dim, labels in DIM_LABELS.items():  # an empty or odd-sized matrix: no labels
        if dim in ds.coords and ds.sizes.get(dim) != len(labels):
            ds = ds.drop_vars(dim)
    ds.attrs.update(_attrs(g.attrs))
    ds.attrs["group"] = name
    return ds


def products_attrs(f: h5py.File) -> dict[str, Any]:
    """A products file's root attributes, NetCDF-safe (:func:`attr_value`)."""
    return _attrs(f.attrs)


def check_products_file(f: h5py.File, path: str | os.PathLike) -> None:
    """Raise FormatError unless ``f`` is an arrayproc products file."""
    from arrayproc.io.products import FORMAT
    if as_text(f.attrs.get("format", "")) != FORMAT:
        raise FormatError(f"{path}: not an arrayproc products file")


def table_frame(ds: Any) -> Any:
    """A table-kind Dataset as a ``pandas.DataFrame``: one row per row, a matrix column as one
    array per row; the dataset's attributes under ``.attrs``."""
    import pandas as pd
    cols: dict[str, Any] = {}
    n = ds.sizes.get("obs", 0)
    for name, v in ds.data_vars.items():
        a = np.asarray(v.values)
        if a.dtype.kind == "S":
            a = np.array([as_text(x) for x in a], dtype=object)
        cols[name] = list(a) if a.ndim > 1 else a
    df = pd.DataFrame(cols, index=pd.RangeIndex(n, name="obs"))
    df.attrs.update(ds.attrs)
    df.attrs["units"] = {n: v.attrs.get("units", "") for n, v in ds.data_vars.items()}
    return df


class LabelledProducts(dict):
    """What :func:`open_products` returns: ``{group name: Dataset or DataFrame}`` in file
    order, the file's root attributes in :attr:`attrs`; :meth:`close` (or ``with``) closes
    the file behind the lazy arrays."""

    def __init__(self, path: str, attrs: dict[str, Any], file: h5py.File | None) -> None:
        super().__init__()
        self.path = path
        self.attrs = attrs
        self._file = file

    def close(self) -> None:
        """Close the products file (lazy arrays cannot be computed after)."""
        if self._file is not None:
            self._file.close()
            self._file = None

    def __enter__(self) -> LabelledProducts:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def open_products(path: str | os.PathLike, lazy: bool | None = None,
                  tables: str = "pandas") -> LabelledProducts:
    """Every group of a products file as labelled arrays.

    Parameters
    ----------
    path : str or path-like
        Products (or tracks) file.
    lazy : bool, optional
        Dask arrays for every dataset (True), none (False), or for datasets larger than
        :data:`LAZY_BYTES` (None, the default).
    tables : {"pandas", "xarray"}
        Tables as ``pandas.DataFrame`` (default) or as ``xarray.Dataset`` with dimension
        ``obs`` (what :func:`arrayproc.io.array_exports.write_arrays` writes).

    Returns
    -------
    LabelledProducts
        ``{name: xarray.Dataset (power, btr, lofar, delays, range_doppler) or
        pandas.DataFrame (the other kinds)}``; groups of a kind this version does not know are
        left out.

    Examples
    --------
    >>> import os, tempfile
    >>> import numpy as np
    >>> import arrayproc as ap
    >>> tmp = tempfile.TemporaryDirectory()
    >>> path = os.path.join(tmp.name, "products.h5")
    >>> with ap.ProductsWriter(path) as out:
    ...     g = out.group("btr", "btr")
    ...     g.set("cone_deg", np.array([0.0, 90.0, 180.0]))
    ...     g.append(time=np.array([0.5, 1.5]), power_db=np.zeros((2, 3), np.float32))
    >>> with ap.open_products(path) as p:
    ...     print(dict(p["btr"].sizes), p["btr"].power_db.attrs["units"])
    {'time': 2, 'cone_deg': 3} dB
    >>> tmp.cleanup()
    """
    if tables not in ("pandas", "xarray"):
        raise FormatError(f"open_products: tables must be 'pandas' or 'xarray', not {tables!r}")
    f = open_h5(path, "products file")
    try:
        check_products_file(f, path)
        out = LabelledProducts(str(path), products_attrs(f), None)
        for name, g in list(f.items()):  # not while dask reads in threads
            if not isinstance(g, h5py.Group) or as_text(g.attrs.get("kind", "")) not in KINDS:
                continue
            ds = group_dataset(f, name, lazy)
            ds.attrs.update({f"file_{k}": v for k, v in out.attrs.items()
                             if k not in ds.attrs})
            kind = as_text(g.attrs["kind"])
            out[name] = ds if kind in GRIDDED or tables == "xarray" else table_frame(ds)
    except BaseException:
        f.close()
        raise
    out._file = f
    return out


def open_recording(path: str | os.PathLike, lazy: bool = True,
                   positions: np.ndarray | None = None) -> Any:
    """A recording's samples as an ``xarray.Dataset``.

    Parameters
    ----------
    path : str or path-like
        Recording file.
    lazy : bool
        ``time_data`` as a dask array read in HDF5 chunks (default), or read whole.
    positions : (n_channels, 3) array, optional
        Element positions, as :class:`arrayproc.io.recording.Recording` takes them.

    Returns
    -------
    xarray.Dataset
        ``time_data`` (time, channel) in the recording's unit (attribute ``units``: ``Pa`` or
        ``FS``), gains applied and dead channels dropped; coordinates ``time`` (s since the
        start, a range index: nothing is allocated), ``channel`` (index in the file) and the
        body-frame ``x``, ``y``, ``z`` of each element; attributes ``sample_freq``,
        ``sound_speed``, ``start_time`` and the file's root attributes.
    """
    from arrayproc.io.recording import Recording
    xr = _xr()
    from xarray.indexes import RangeIndex
    rec = Recording(path, positions=positions, require_geometry=False)
    td = rec._td
    if lazy:
        import dask.array as da
        x = da.from_array(td, chunks=td.chunks or "auto", lock=True)
    else:
        x = td[()]
    if rec._select is not None:
        x = x[:, rec.channels]
    if rec._apply_gain:
        x = x * rec.gains.astype(td.dtype if td.dtype.kind == "f" else np.float32)
    units = rec.units
    label = "sound pressure" if units == "Pa" else f"sample value ({units})"
    idx = RangeIndex.linspace(0.0, rec.n_samples / rec.fs, rec.n_samples, endpoint=False,
                              dim="time")
    coords = xr.Coordinates.from_xindex(idx)
    ds = xr.Dataset({"time_data": (("time", "channel"), x,
                                   {"units": units, "long_name": label})}, coords=coords)
    ds.coords["time"].attrs.update(units="s", long_name="time since the recording's start")
    p = rec.positions
    ds = ds.assign_coords(
        channel=("channel", rec.channels, {"long_name": "channel index in the file"}),
        x=("channel", p[:, 0], {"units": "m", "long_name": "element x, body frame forward"}),
        y=("channel", p[:, 1], {"units": "m", "long_name": "element y, body frame starboard"}),
        z=("channel", p[:, 2], {"units": "m", "long_name": "element z, body frame down"}))
    ds.attrs.update(_attrs(rec._f.attrs))
    ds.attrs.update(sample_freq=rec.fs, sound_speed=rec.sound_speed, units=units)
    if "calibration" in td.attrs:
        ds.attrs["calibration"] = as_text(td.attrs["calibration"])
    if not lazy:
        rec.close()
    return ds
