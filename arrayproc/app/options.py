"""The options several commands share, declared once so that each flag means one thing on
every command (a test walks the parser: tests/app/test_cli_flags.py):

* ``-q, --quiet``: print nothing on stdout; errors and warnings still go to stderr and the exit
  status tells the outcome (every command has it); ``-v, --verbose``: the package's debug
  log records on stderr too (:mod:`arrayproc.app.logs`);
* ``-c, --config``: the configuration file the command runs (a chain, a tracker, a TMA
  configuration; ``--chain`` is an alias where a chain is meant);
* ``-o, --output``: the file or folder to write;
* ``--no-progress``; ``--line N SPACING`` / ``--geometry FILE`` / ``--z-up``.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from typing import TYPE_CHECKING

from arrayproc.errors import FormatError

if TYPE_CHECKING:
    import numpy as np

QUIET_HELP = "print nothing on stdout (errors and warnings still go to stderr)"
VERBOSE_HELP = "log more on stderr: debug detail as well as information (logging)"


def finite(v: float) -> bool:
    """Whether a number given on the command line is finite (not NaN or ±Inf)."""
    return v == v and v not in (float("inf"), float("-inf"))


def add_quiet(p: argparse.ArgumentParser) -> None:
    """``-q, --quiet`` with its one meaning (:data:`QUIET_HELP`), and ``-v, --verbose``
    (:data:`VERBOSE_HELP`): the levels of the package's logging (:mod:`arrayproc.app.logs`;
    ``-q`` also keeps information off stderr)."""
    p.add_argument("-q", "--quiet", action="store_true", help=QUIET_HELP)
    p.add_argument("-v", "--verbose", action="count", default=0, help=VERBOSE_HELP)


def add_no_progress(p: argparse.ArgumentParser) -> None:
    """``--no-progress``: no progress bar on stderr."""
    p.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")


def add_config(p: argparse.ArgumentParser, what: str, alias: str | None = None) -> None:
    """``-c, --config FILE`` (required), the configuration the command runs, stored as
    ``args.config``; ``alias`` (e.g. ``--chain``) is accepted as another long name."""
    names = ["-c", "--config", *([alias] if alias else [])]
    p.add_argument(*names, dest="config", required=True, metavar="FILE", help=what)


def add_output(p: argparse.ArgumentParser, what: str, required: bool = True,
               default: str | None = None, metavar: str | None = None) -> None:
    """``-o, --output``: what the command writes."""
    p.add_argument("-o", "--output", required=required, default=default, metavar=metavar,
                   help=what)


def geometry(line: Sequence[float] | None = None, geometry_file: str | None = None,
             z_up: bool = False) -> np.ndarray | None:
    """Element positions from ``--line N SPACING`` or a geometry file, else None.

    Parameters
    ----------
    line : (N, spacing), optional
        Uniform line array of N elements, spacing m apart.
    geometry_file : str, optional
        CSV (x, y, z columns) or acoular XML file of positions, m.
    z_up : bool
        The file's z axis points up (arrayproc's body frame has z down): z is negated.

    Returns
    -------
    ndarray (n, 3) or None
        Body-frame positions, m.
    """
    from arrayproc.io.geometry import line_array, read_geometry
    if line is not None:
        n, spacing = line
        if not (n == int(n) if finite(n) else False) or not 1 <= n <= 1_000_000:
            raise FormatError(f"--line N SPACING: N must be a whole number in 1..1000000, "
                              f"got {n:g}")
        if not (finite(spacing) and spacing > 0):
            raise FormatError(f"--line N SPACING: SPACING must be a finite number > 0 m, "
                              f"got {spacing:g}")
        return line_array(int(n), spacing)
    if geometry_file:
        pos = read_geometry(geometry_file)
        if z_up:
            pos = pos.copy()
            pos[:, 2] = -pos[:, 2]
        return pos
    return None


def add_calibration_options(p: argparse.ArgumentParser) -> None:
    """``--sensitivity DB`` / ``--response CSV``, ``--gain DB``, ``--full-scale-volts V``: the
    samples of an import in pascals (:mod:`arrayproc.io.calibration`)."""
    p.add_argument("--sensitivity", type=float, default=None, metavar="DB",
                   help="hydrophone sensitivity, dB re 1 V/µPa (e.g. -170): samples stored in "
                        "Pa, levels in dB re 1 µPa; needs --full-scale-volts")
    p.add_argument("--gain", type=float, default=None, metavar="DB",
                   help="gain between hydrophone and recorder, dB (default 0)")
    p.add_argument("--full-scale-volts", type=float, default=None, metavar="V",
                   help="voltage of the recorder's full scale (sample value 1), V")
    p.add_argument("--response", default=None, metavar="CSV",
                   help="frequency response instead of --sensitivity: CSV rows of freq_hz, "
                        "sensitivity_db (re 1 V/µPa), corrected as a filter")


def add_geometry_options(p: argparse.ArgumentParser) -> None:
    """``--line N SPACING`` / ``--geometry FILE`` (mutually exclusive)."""
    g = p.add_mutually_exclusive_group()
    g.add_argument("--line", nargs=2, type=float, metavar=("N", "SPACING"),
                   help="uniform line array of N elements SPACING m apart")
    g.add_argument("--geometry", metavar="FILE",
                   help="element positions: CSV with x,y,z columns or acoular XML")
    p.add_argument("--z-up", action="store_true",
                   help="the geometry file's z axis points up (arrayproc's points down)")


def geometry_of(args: argparse.Namespace):
    """The positions ``--line`` or ``--geometry`` give (:func:`geometry`), else None."""
    return geometry(getattr(args, "line", None), getattr(args, "geometry", None),
                    z_up=getattr(args, "z_up", False))


def geometry_inputs(args: argparse.Namespace) -> list[str]:
    """The geometry file among a command's inputs (an output must not replace it)."""
    return [args.geometry] if getattr(args, "geometry", None) else []
