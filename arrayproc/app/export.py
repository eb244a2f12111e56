"""``arrayproc export``: products or tracks files written in an exchange format (Raven
selection tables, Debrief replay files; :mod:`arrayproc.io.exports`), atomically.
"""

from __future__ import annotations

from collections.abc import Sequence

from arrayproc.errors import ConfigError
from arrayproc.io.atomic import check_output


def export(files: Sequence[str], to: str, output: str,
           origin: tuple[float, float] = (0.0, 0.0)) -> int:
    """Write products or tracks files in an exchange format (Raven selection tables, Debrief REP).

    Parameters
    ----------
    files : sequence of str
        ``raven``: products files with detections or bearings, consecutive recordings in time
        order; ``rep``: one tracks file or products file with bearings.
    to : {"raven", "rep"}
        Raven selection table or Debrief replay file.
    output : str
        Text file to write.
    origin : (float, float)
        ``rep``: latitude and longitude (deg) of the world frame's origin.

    Returns
    -------
    int
        Selections (raven) or lines (rep) written.
    """
    from arrayproc.io import exports
    from arrayproc.io.atomic import atomic_path
    if to not in ("raven", "rep"):
        raise ConfigError(f"export: --to must be raven or rep, not {to!r}")
    if to == "rep" and len(files) != 1:
        raise ConfigError("export: --to rep takes one file")
    check_output(output, list(files))
    with atomic_path(output) as tmp:
        n = (exports.write_raven(list(files), str(tmp)) if to == "raven"
             else exports.write_rep(files[0], str(tmp), origin=origin))
    return n
