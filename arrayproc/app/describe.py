"""``arrayproc info``: a description of a recording or products file that is cheap on any file.

Only attributes, dataset shapes and the small metadata datasets (positions, gains, nav) are
read, never the samples or product columns; the aperture costs O(n) memory for n elements
(:func:`arrayproc.io.geometry.aperture`). A file in acoular's layout without geometry is
described (layout, channels, rate, duration) with a note on how to give the geometry.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import h5py

from arrayproc.errors import FormatError
from arrayproc.io.h5 import _attr_str, get_object, open_h5
from arrayproc.io.units import file_units, level_label

#: Geometry summaries (line / planar / volumetric, aperture) up to this many elements.
MAX_GEOMETRY_ELEMENTS = 100_000


def info(path: str, positions: Any = None, echo: Callable[[str], None] = print) -> None:
    """Describe a recording or a products file, cheaply on any file.

    Only attributes, shapes and small datasets are read (never the samples); the aperture of
    n elements costs O(n) memory.

    Parameters
    ----------
    path : str
        Recording or products HDF5 file.
    positions : (n, 3) array, optional
        Geometry for a file that has none (acoular layout).
    echo : callable
        Where each line of the description goes.
    """
    for line in describe(path, positions):
        echo(line)


def describe(path: str, positions: Any = None) -> list[str]:
    """Lines describing a recording or products file.

    Parameters
    ----------
    path : str
        HDF5 file.
    positions : (n, 3) array, optional
        Geometry given by the user (overrides the file's).

    Returns
    -------
    list of str
        The description, one line each.
    """
    from arrayproc.io.products import FORMAT as PRODUCTS
    with open_h5(path) as f:
        fmt = _attr_str(f.attrs.get("format", ""))
    if fmt == PRODUCTS:
        return _describe_products(path)
    return _describe_recording(path, positions)


def _describe_products(path: str) -> list[str]:
    with open_h5(path, "products file") as f:
        a = f.attrs
        lines = [f"{path}: arrayproc products, format version "
                 f"{_attr_str(a.get('format_version', '?'))}, complete="
                 f"{_attr_str(a.get('complete', False))}",
                 f"  source: {_attr_str(a.get('source', ''))}"]
        if "units" in a:  # the recording's sample unit, which the levels follow
            lines.append(f"  units: {file_units(a)} (levels in {level_label(file_units(a))})")
        for name in f:
            g = get_object(f, Path(path), name)
            if isinstance(g, h5py.Group):
                lines.append(_group_line(f, path, name, g))
    return lines


def _group_line(f: h5py.File, path: str, name: str, g: h5py.Group) -> str:
    """``name: kind=K rows=N columns=… axes=a (n), …`` for one products group.

    Rows are the length of the kind's row columns (:mod:`arrayproc.io.schema`); the axes (e.g.
    ``cone_deg`` of a BTR) are static datasets whose length is the axis length, not a row
    count. For a kind this version does not know, every dataset is taken for a column.
    """
    from arrayproc.io.schema import KINDS
    k_name = _attr_str(g.attrs.get("kind", ""))
    k = KINDS.get(k_name)
    cols, axes, rows = [], [], set()
    for key in g:
        d = get_object(f, Path(path), f"{name}/{key}")
        if not isinstance(d, h5py.Dataset):
            continue
        n = int(d.shape[0]) if d.ndim else 1
        if k is not None and key in k.axes and key not in k.columns:
            axes.append(f"{key} ({n})")
        else:
            cols.append(key)
            rows.add(n)
    n_rows = "0" if not rows else str(max(rows)) if len(rows) == 1 else \
        f"{min(rows)}-{max(rows)} (columns of unequal length)"
    line = f"  {name}: kind={k_name} rows={n_rows} columns={', '.join(cols) or 'none'}"
    return line + (f" axes={', '.join(axes)}" if axes else "")


def _describe_recording(path: str, positions: Any) -> list[str]:
    from arrayproc.io.geometry import aperture, geometry_kind
    from arrayproc.io.recording import Recording
    with Recording(path, positions=positions, require_geometry=False) as r:
        layout = (f"arrayproc recording, format version {r.format_version}"
                  if r.layout == "arrayproc" else "acoular layout (no format attributes: "
                  "defaults applied)")
        lines = [f"{path}: {layout}",
                 f"  channels: {r.n_channels} active of {r.n_channels_file}",
                 f"  sample rate: {r.fs:g} Hz, samples: {r.n_samples}, duration: "
                 f"{r.duration:.3f} s, units: {r.units}",
                 f"  sound speed: {r.sound_speed:g} m/s, start: {r.start_time or 'unknown'}"]
        if r.geometry_source == "none":
            lines.append(f"  geometry: none in the file; give it with --line N SPACING or "
                         f"--geometry FILE (CSV x,y,z or acoular XML, {r.n_channels_file} "
                         "rows) to info and process")
        elif r.n_channels > MAX_GEOMETRY_ELEMENTS:
            lines.append(f"  geometry: {r.n_channels} elements ({r.geometry_source}); shape "
                         "not summarised above "
                         f"{MAX_GEOMETRY_ELEMENTS} elements")
        else:
            lines.append(f"  geometry: {geometry_kind(r.positions)} ({r.geometry_source}), "
                         f"aperture {aperture(r.positions):.3f} m")
        nav = r.nav
        if nav.time.size > 1:
            lo, hi = nav.position.min(0), nav.position.max(0)
            lines.append(f"  nav: {nav.time.size} fixes over {nav.time[0]:.1f}-"
                         f"{nav.time[-1]:.1f} s, x {lo[0]:.1f}..{hi[0]:.1f} m, y "
                         f"{lo[1]:.1f}..{hi[1]:.1f} m")
        else:
            lines.append(f"  nav: static at ({nav.position[0, 0]:.1f}, "
                         f"{nav.position[0, 1]:.1f}) m, heading {nav.heading[0]:.1f} deg")
        truth = _truth_summary(r)
        if truth:
            lines.append(truth)
    return lines


def _truth_summary(r: Any) -> str:
    """``truth: N source(s)[, pings]`` from the group names only (no data read)."""
    f, p = r._f, r.path
    t = get_object(f, p, "truth")
    if t is None:
        return ""
    if not isinstance(t, h5py.Group):
        raise FormatError(f"{p}: /truth must be a group (simulator truth), not a dataset")
    src = t.get("sources")
    n_src = len(src) if isinstance(src, h5py.Group) else 0
    return f"  truth: {n_src} source(s)" + (", pings" if "pings" in t else "")


__all__ = ["describe"]
