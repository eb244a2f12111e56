"""``arrayproc export``: products or tracks files written in an exchange format (Raven
selection tables, Debrief replay files; :mod:`arrayproc.io.exports`) or as labelled arrays
(NetCDF4, Zarr; :mod:`arrayproc.io.array_exports`), atomically.
"""

from __future__ import annotations

from collections.abc import Sequence

from arrayproc.errors import ConfigError
from arrayproc.io.atomic import check_output

#: What ``--to`` accepts.
FORMATS = ("raven", "rep", "netcdf", "zarr")


def export(files: Sequence[str], to: str, output: str,
           origin: tuple[float, float] = (0.0, 0.0)) -> int:
    """Write products or tracks files in an exchange format (Raven selection tables, Debrief
    REP) or as NetCDF4 / Zarr (one group per products group).

    Parameters
    ----------
    files : sequence of str
        ``raven``: products files with detections or bearings, consecutive recordings in time
        order; ``rep``: one tracks file or products file with bearings; ``netcdf``, ``zarr``:
        one products or tracks file.
    to : {"raven", "rep", "netcdf", "zarr"}
        Raven selection table, Debrief replay file, NetCDF4 file or Zarr store.
    output : str
        Text file, NetCDF file or Zarr store (directory) to write.
    origin : (float, float)
        ``rep``: latitude and longitude (deg) of the world frame's origin.

    Returns
    -------
    int
        Selections (raven), lines (rep) or groups (netcdf, zarr) written.
    """
    from arrayproc.io import exports
    from arrayproc.io.atomic import atomic_path
    if to not in FORMATS:
        raise ConfigError(f"export: --to must be one of {', '.join(FORMATS)}, not {to!r}")
    if to != "raven" and len(files) != 1:
        raise ConfigError(f"export: --to {to} takes one file")
    if to in ("netcdf", "zarr"):
        from arrayproc.io.array_exports import write_arrays
        if to == "netcdf":
            check_output(output, list(files))
        return write_arrays(files[0], output, to)
    check_output(output, list(files))
    with atomic_path(output) as tmp:
        n = (exports.write_raven(list(files), str(tmp)) if to == "raven"
             else exports.write_rep(files[0], str(tmp), origin=origin))
    return n
