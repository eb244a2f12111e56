"""Products files (docs/formats.md): groups of columns appended as blocks come.

Each group is named after the producing stage and carries attrs ``kind`` and ``stage``. Column
datasets are resizable along their first axis, chunked and compressed; static datasets (axes
such as ``cone_deg`` or ``freq``) are written once. The file is built under a temporary name and
renamed only when the run finished, with root attr ``complete = True``; a live run
(``process --follow``) writes the file in place in SWMR mode, readable while it grows, and sets
``complete`` at its end.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from arrayproc.errors import FormatError
from arrayproc.io.atomic import AtomicH5Writer, check_stop
from arrayproc.io.h5 import get_object, open_h5
from arrayproc.io.schema import KINDS, check_columns, check_group, empty_columns, groups_of_kind
from arrayproc.io.schema import kind as schema_kind
from arrayproc.io.text import as_text

FORMAT = "arrayproc.products"
FORMAT_VERSION = 1

#: Target size of one chunk of a column dataset, bytes.
CHUNK_BYTES = 1 << 18

#: gzip level 1 with byte shuffle, for table columns and small rows (any HDF5 tool reads it).
GZIP = {"compression": "gzip", "compression_opts": 1, "shuffle": True}
#: rows larger than this (a LOFAR row of every beam: beams x bins float32) are stored
#: uncompressed, with HDF5's Fletcher-32 checksum per chunk (gzip's own checks a compressed
#: chunk), so damage is found on reading: measured on the towed chain (64 channels,
#: 181 beams x 901 bins), gzip saved 16 % of the LOFAR's bytes for 45 % of the chain's
#: CPU (docs/performance/startup.md).
COMPRESS_MAX_ROW_BYTES = 64 * 1024


class GroupWriter:
    """Appends rows to one products group.

    ``time_window`` (t_start, t_stop) drops rows whose ``time`` (else ``time_start`` or ``t0``)
    falls outside it: this is how a segment with a warm-up margin writes only its own rows.
    """

    def __init__(self, group: h5py.Group, time_window: tuple[float, float] | None = None,
                 kind: str | None = None):
        self._g = group
        self._window = time_window
        self.kind = kind
        self._checked: set[str] = set()
        self.n_rows = 0

    def _check(self, names: set[str]) -> None:
        """Every dataset name must be declared for the group's kind (io/schema.py)."""
        if self.kind is not None and not names <= self._checked:
            check_columns(self.kind, names, self._g.name)
            self._checked |= names

    @property
    def attrs(self) -> h5py.AttributeManager:
        return self._g.attrs

    def set(self, name: str, data: np.ndarray, **attrs: Any) -> None:
        """Write a static dataset (e.g. an axis), replacing any earlier one."""
        self._check({name})
        if name in self._g:
            del self._g[name]
        d = self._g.create_dataset(name, data=np.asarray(data))
        for k, v in attrs.items():
            d.attrs[k] = v

    def _create(self, name: str, v: np.ndarray) -> None:
        """A row column of ``v``'s dtype and row shape, resizable along the rows (also along
        a dimension of size 0: the empty table of a kind whose sizes the data sets)."""
        row = v.shape[1:]
        row_bytes = max(1, int(np.prod(row)) * v.dtype.itemsize)
        chunk_rows = max(1, min(4096, CHUNK_BYTES // row_bytes))
        self._g.create_dataset(
            name, shape=(0,) + row, maxshape=(None,) + tuple(n or None for n in row),
            dtype=v.dtype, chunks=(chunk_rows,) + tuple(max(1, n) for n in row),
            **({"fletcher32": True} if row_bytes > COMPRESS_MAX_ROW_BYTES else GZIP))

    def fill_empty(self) -> None:
        """A group that received no rows gets every required column of its kind with 0 rows
        and the declared dtype (:func:`arrayproc.io.schema.empty_columns`): a stage that
        found nothing writes a valid empty table, not a group without columns."""
        if self.kind is None or self.n_rows > 0:
            return
        for k, v in empty_columns(self.kind).items():
            if k not in self._g:
                self._create(k, v)

    def append(self, **columns: np.ndarray) -> None:
        """Append rows: every column has the same length along its first axis."""
        check_stop()
        self._check(set(columns))
        cols = {k: np.asarray(v) for k, v in columns.items()}
        lengths = {v.shape[0] if v.ndim else 1 for v in cols.values()}
        if len(lengths) != 1:
            shapes = {k: v.shape for k, v in cols.items()}
            raise ValueError(f"columns of unequal length: {shapes}")
        cols = {k: (v.reshape(1) if v.ndim == 0 else v) for k, v in cols.items()}
        tcol = next((c for c in ("time", "time_start", "t0") if c in cols), None)
        if self._window is not None and tcol is not None:
            t = cols[tcol]
            keep = (t >= self._window[0]) & (t < self._window[1])
            if not keep.all():
                cols = {k: v[keep] for k, v in cols.items()}
        n = next(iter(cols.values())).shape[0]
        if n == 0 and self.n_rows > 0:
            return
        for k, v in cols.items():
            if k not in self._g:
                self._create(k, v)
            d = self._g[k]
            if d.shape[1:] != v.shape[1:]:
                raise ValueError(f"column {k}: row shape {v.shape[1:]} != {d.shape[1:]}")
            d.resize(self.n_rows + n, axis=0)
            d[self.n_rows:self.n_rows + n] = v
        self.n_rows += n


class ProductsWriter(AtomicH5Writer):
    """Writes a products file; use as a context manager so a failed run leaves nothing behind."""

    def __init__(self, path: str | os.PathLike, source: str = "", chain: str = "",
                 time_window: tuple[float, float] | None = None,
                 attrs: dict[str, Any] | None = None, live: bool = False) -> None:
        super().__init__(path, source, chain, time_window, attrs, live=live)

    def _start(self, source: str, chain: str, time_window: tuple[float, float] | None,
               attrs: dict[str, Any] | None) -> None:
        a = self._f.attrs
        a["format"] = FORMAT
        a["format_version"] = FORMAT_VERSION
        a["source"] = str(source)
        a["chain"] = chain
        import arrayproc
        a["software_version"] = arrayproc.__version__
        a["complete"] = False
        for k, v in (attrs or {}).items():
            a[k] = v
        self._window = time_window
        self._groups: dict[str, GroupWriter] = {}

    def group(self, name: str, kind: str, stage: str | None = None,
              **attrs: Any) -> GroupWriter:
        """The writer for group ``name`` (created on first use) of product ``kind``."""
        if name in self._groups:
            return self._groups[name]
        if not name or "/" in name or name in (".", ".."):
            raise FormatError(f"{self.path}: products group name {name!r} is not a plain name "
                              "(no '/', not '.' or '..')")
        schema_kind(kind)  # a declared kind (FormatError otherwise)
        g = self._f.create_group(name)
        g.attrs["kind"] = kind
        g.attrs["stage"] = stage or name
        for k, v in attrs.items():
            g.attrs[k] = v
        w = GroupWriter(g, self._window, kind)
        self._groups[name] = w
        return w

    def set_units(self, units: str) -> None:
        """Root attribute ``units``: the sample unit of the recording the products come from
        (``"Pa"``, ``"FS"``; :mod:`arrayproc.io.units`), which every level label follows."""
        self._f.attrs["units"] = str(units)

    def _finish(self) -> None:
        for w in self._groups.values():
            w.fill_empty()
        self._f.attrs["complete"] = True  # only a finished run is marked complete


def is_products(path: str | os.PathLike) -> bool:
    """Whether the file at path is an arrayproc products file."""
    with open_h5(path) as f:
        fmt = f.attrs.get("format", "")
        return as_text(fmt) == FORMAT


def product_kinds(path: str | os.PathLike) -> list[str]:
    """The ``kind`` attribute of every group of a products file, in file order (no data read).

    Raises FormatError when the file is not an arrayproc products file.
    """
    with open_h5(path, "products file") as f:
        if _attr_str(f.attrs.get("format", "")) != FORMAT:
            raise FormatError(f"{path}: not an arrayproc products file")
        return [_attr_str(g.attrs.get("kind", "")) for g in f.values()
                if isinstance(g, h5py.Group)]


def group_names(f: h5py.File, kind: str) -> list[str]:
    """Names of the groups of ``kind`` in an open products file, in file order, without reading
    any data (the shape checks of the commands; :meth:`ProductsFile.groups` on a read file).

    Parameters
    ----------
    f : h5py.File
        An open products file.
    kind : str
        A declared product kind (FormatError otherwise).

    Returns
    -------
    list of str
    """
    schema_kind(kind)
    where = Path(f.filename)
    return [n for n in f if isinstance(get_object(f, where, n), h5py.Group)
            and _attr_str(f[n].attrs.get("kind", "")) == kind]


def products_source(path: str | os.PathLike) -> str:
    """The root attribute ``source`` of a products file (the recording it was made from)."""
    with open_h5(path, "products file") as f:
        return _attr_str(f.attrs.get("source", ""))


def _attr_str(v: Any) -> str:
    if isinstance(v, bytes):
        return v.decode(errors="replace")
    if isinstance(v, str):
        return v
    if isinstance(v, np.ndarray) and v.size == 1:
        return _attr_str(v.reshape(-1)[0])
    return str(v) if isinstance(v, (np.generic, int, float)) else ""


class ProductGroup(dict):
    """One products group as read: ``{"kind", "stage", "attrs", dataset: array}``, with its
    ``name`` and its ``kind`` as text."""

    def __init__(self, name: str, data: dict[str, Any]) -> None:
        super().__init__(data)
        self.name = name

    @property
    def kind(self) -> str:
        """The group's product kind (:mod:`arrayproc.io.schema`)."""
        return as_text(self.get("kind", ""))


class ProductsFile(dict):
    """A products file as read by :func:`read_products`: ``{name: ProductGroup}`` in file
    order, with the root attributes under the key ``"/"`` (also :attr:`root`).

    :meth:`groups` is the one way to find the groups of a kind.
    """

    def __init__(self, path: str, root: dict[str, Any]) -> None:
        super().__init__({"/": root})
        self.path = path

    @property
    def root(self) -> dict[str, Any]:
        """The file's root attributes."""
        return self["/"]

    def groups(self, kind: str) -> dict[str, ProductGroup]:
        """The groups of one product kind, in file order.

        Parameters
        ----------
        kind : str
            A kind declared in :mod:`arrayproc.io.schema` (FormatError otherwise: a misspelt
            kind is refused, not answered with no group).

        Returns
        -------
        dict
            ``{name: ProductGroup}``, empty when the file has no group of that kind.
        """
        schema_kind(kind)
        return {n: self[n] for n in groups_of_kind(self, kind)}

    def kinds(self) -> list[str]:
        """The kind of every group, in file order."""
        return [as_text(g.get("kind")) for n, g in self.items() if n != "/"]


def read_products(path: str | os.PathLike) -> ProductsFile:
    """Every group of a products file, its columns checked against :mod:`arrayproc.io.schema`.

    Parameters
    ----------
    path : str or path-like
        Products file.

    Returns
    -------
    ProductsFile
        ``{name: {"kind", "stage", "attrs", dataset: array}}``; the root attributes are under
        the key ``"/"``; ``.groups(kind)`` selects the groups of one kind.

    Raises
    ------
    FormatError
        Not a products file, or a group lacks a required column of its kind.

    Examples
    --------
    A group written by hand (a stage does the same through its ``products(kind)`` writer):

    >>> import os, tempfile
    >>> import numpy as np
    >>> from arrayproc import ProductsWriter, read_products
    >>> tmp = tempfile.TemporaryDirectory()
    >>> path = os.path.join(tmp.name, "products.h5")
    >>> with ProductsWriter(path) as out:
    ...     out.group("power", "power", "power").append(
    ...         time=np.array([0.5, 1.5]), power_db=np.array([[60.0, 61.0], [62.0, 63.0]]))
    >>> groups = read_products(path)
    >>> groups["power"]["kind"], groups["power"]["power_db"].shape
    ('power', (2, 2))
    >>> tmp.cleanup()
    """
    with open_h5(path, "products file") as f:
        fmt = f.attrs.get("format", "")
        if as_text(fmt) != FORMAT:
            raise FormatError(f"{path}: not an arrayproc products file")
        out = ProductsFile(str(path), dict(f.attrs))
        for name, g in f.items():
            if not isinstance(g, h5py.Group):
                continue
            d: dict[str, Any] = {"kind": g.attrs.get("kind", ""), "stage": g.attrs.get("stage", ""),
                                 "attrs": dict(g.attrs)}
            for k, v in g.items():
                if isinstance(v, h5py.Dataset):
                    d[k] = _read_dataset(v, path, f"{name}/{k}")
            check_group(name, d, str(path))
            _fill_empty_group(d)
            out[name] = ProductGroup(name, d)
        return out


def _read_dataset(v: h5py.Dataset, path: Any, where: str) -> Any:
    """A dataset's values; a damaged chunk (failed checksum or decompression) is a
    FormatError naming the file, the dataset and the first row that cannot be read."""
    try:
        return v[()]
    except (OSError, ValueError, RuntimeError) as e:
        from arrayproc.io.h5 import damage_reason, first_bad_row
        row, text = first_bad_row(v, 0, v.shape[0]) if v.ndim and v.chunks else (0, "")
        raise FormatError(f"{path}: /{where} is damaged from row {row}: "
                          f"{damage_reason(text or str(e))}") from None


def _fill_empty_group(d: dict[str, Any]) -> None:
    """A group of a declared kind with no column at all (what a stage that found nothing
    wrote before empty groups were filled on writing) is read as the empty table of its
    kind."""
    k = KINDS.get(as_text(d["kind"]))
    if k is None or any(c in d for c in k.columns):
        return
    for c, v in empty_columns(k.name).items():
        d[c] = v


def delays_columns(group: dict, path: str) -> dict[str, Any]:
    """The rows of a ``delays`` group, checked and sorted by time.

    Parameters
    ----------
    group : dict
        The group as returned by :func:`read_products`.
    path : str
        Products file, for the messages.

    Returns
    -------
    dict
        ``time`` (n,) s, ``tau`` (n, n_ch) s, ``sigma`` and ``corr`` (n, n_ch) or None when the
        group has no such column, ``reference`` (the reference channel, attribute, default 0)
        and ``order`` (the permutation that sorted the rows by time, stable).

    Raises
    ------
    FormatError
        A column is missing or shaped unlike ``tau`` (n, n_ch).
    """
    for k in ("time", "tau"):
        if k not in group:
            raise FormatError(f"{path}: delays column {k!r} is missing")
    t = np.asarray(group["time"], float).reshape(-1)
    tau = np.asarray(group["tau"], float)
    if tau.ndim != 2 or tau.shape[0] != t.size:
        raise FormatError(f"{path}: delays 'tau' must be (n, n_ch) with n = {t.size}")
    order = np.argsort(t, kind="stable")
    out: dict[str, Any] = {"time": t[order], "tau": tau[order], "order": order,
                           "reference": int(group.get("attrs", {}).get("reference", 0))}
    for k in ("sigma", "corr"):
        v = None
        if k in group:
            v = np.asarray(group[k], float)
            if v.shape != tau.shape:
                raise FormatError(f"{path}: delays {k!r} shape {v.shape} != tau {tau.shape}")
            v = v[order]
        out[k] = v
    return out
