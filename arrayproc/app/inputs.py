"""What a reader needs of a products file, checked before it reads any data.

A plot or a tracker names the product kind and the columns it reads; their number of
dimensions and the axes that label them come from the schema (:mod:`arrayproc.io.schema`:
``Column.trailing`` and ``Column.labels``), so this module holds no copy of the columns. Only
shapes and types are read.
"""

from __future__ import annotations

from pathlib import Path

from arrayproc.errors import FormatError

#: What each plot reads: the product kind and the columns it needs.
PLOT_INPUTS: dict[str, tuple[str, tuple[str, ...]]] = {
    "btr": ("btr", ("time", "power_db")),
    "lofar": ("lofar", ("time", "power_db")),
    "track": ("tracks", ("time", "x", "y")),
    "bearings": ("bearings", ("time", "bearing_port_deg", "bearing_stbd_deg", "snr_db")),
    "bearing_frequency": ("lofar", ("time", "power_db")),
}

#: What the bearings tracker reads from its products file (same form as PLOT_INPUTS).
TRACK_INPUT: tuple[str, tuple[str, ...]] = (
    "bearings", ("time", "cone_deg", "bearing_port_deg", "bearing_stbd_deg"))


def check_plot_input(path: str, kind: str) -> None:
    """Refuse a products file whose groups cannot make the ``kind`` plot (FormatError naming
    the group and column): missing or non-numeric columns, wrong dimensions, no rows, axes
    that do not match the data. Only shapes and types are read."""
    if kind not in PLOT_INPUTS:
        return
    check_product_input(path, kind, PLOT_INPUTS[kind])


def check_product_input(path: str, use: str, spec: tuple[str, tuple[str, ...]],
                        empty_ok: bool = False) -> None:
    """Refuse a products file whose groups of ``spec``'s kind lack a numeric column of the
    dimensions the schema declares, have no rows (unless ``empty_ok``: a reader such as the
    tracker for which no rows is a valid input), or axes that do not match the data (see
    :data:`PLOT_INPUTS`); ``use`` names the reader in the message.

    Parameters
    ----------
    path : str
        Products file.
    use : str
        The reader, for the messages (``"btr"``, ``"the tracker"``).
    spec : (kind, columns)
        The product kind and the columns read.
    empty_ok : bool
        Whether a group with no rows is a valid input.
    """
    import h5py

    from arrayproc.io.h5 import attr_str, get_object, open_h5
    from arrayproc.io.products import FORMAT, group_names
    from arrayproc.io.schema import kind as schema_kind
    pkind, names = spec
    k = schema_kind(pkind)
    cols = {c: 1 + len(k.columns[c].trailing) for c in names}
    with open_h5(path, "products file") as f:
        if attr_str(f.attrs.get("format", "")) != FORMAT:
            raise FormatError(f"{path}: not an arrayproc products file")
        groups = group_names(f, pkind)
        if not groups:
            raise FormatError(f"{path}: no {pkind} group for {use}")
        for name in groups:
            g = f[name]
            where = f"{path}: group {name!r} (kind {pkind!r})"
            if empty_ok and not any(isinstance(g.get(c), h5py.Dataset) for c in cols):
                continue  # no column at all: an older file's empty group, read as empty
            rows = set()
            for col, ndim in cols.items():
                d = get_object(f, Path(path), f"{name}/{col}")
                if not isinstance(d, h5py.Dataset):
                    raise FormatError(f"{where}: no column {col!r}")
                if d.dtype.kind not in "fiu":
                    raise FormatError(f"{where}: column {col!r} must be numeric, has type "
                                      f"{d.dtype}")
                if d.ndim != ndim:
                    raise FormatError(f"{where}: column {col!r} must have {ndim} dimension(s), "
                                      f"has shape {d.shape}")
                rows.add(d.shape[0])
            if len(rows) != 1:
                raise FormatError(f"{where}: columns have different numbers of rows {rows}")
            if rows == {0} and not empty_ok:
                raise FormatError(f"{where}: has 0 rows; nothing to plot")
            for col in cols:
                _check_labels(g, where, col, k.columns[col].labels)


def _check_labels(g, where: str, col: str, labels: tuple) -> None:
    """The axes labelling each trailing dimension of column ``col`` (schema ``labels``) are
    present and as long as that dimension: the first is a beam axis (one of several names),
    the others name one axis each."""
    import h5py
    shape = g[col].shape
    for dim, axes in enumerate(labels, start=1):
        found = [a for a in axes if isinstance(g.get(a), h5py.Dataset)]
        if dim == 1:
            if not found:
                raise FormatError(f"{where}: no beam axis ({' or '.join(axes)})")
            if g[found[0]].shape[0] != shape[1]:
                raise FormatError(f"{where}: axis {found[0]!r} has {g[found[0]].shape[0]} "
                                  f"values but {col!r} has {shape[1]} beams")
        elif not found or g[found[0]].shape[0] != shape[dim]:
            raise FormatError(f"{where}: axis {axes[0]!r} must have {shape[dim]} values")
