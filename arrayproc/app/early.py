"""Stop signals caught from the command's first line.

Before :func:`arrayproc.app.cli.main` installs its handlers, the command imports the parser's
modules (tens of milliseconds); a SIGINT there raised ``KeyboardInterrupt`` with a traceback
and a SIGTERM or SIGHUP ended the process by the signal. :func:`install`, the first thing
``python -m arrayproc`` and the ``arrayproc`` script run, records such a signal instead, and
``main`` stops with the same line and status as a signal later in the run (nothing has been
written yet). Only the interpreter's own start-up, before any arrayproc code runs, is left
(docs/reliability.md gives the measured window).
"""

from __future__ import annotations

import os
import signal
import sys

#: Signals received before the command's handlers were installed, first one first.
EARLY: list[int] = []


def _record(signum: int, frame: object) -> None:
    if not EARLY:
        EARLY.append(int(signum))


def install() -> None:
    """Record SIGINT, SIGTERM and SIGHUP from now on (main thread only)."""
    for name in ("SIGINT", "SIGTERM", "SIGHUP"):
        s = getattr(signal, name, None)
        if s is not None:
            try:
                signal.signal(s, _record)
            except (ValueError, OSError):  # not the main thread
                return


def as_command() -> bool:
    """Whether this process is the ``arrayproc`` command (its script or ``-m arrayproc``),
    not a program that imports the package."""
    arg0 = sys.argv[0] if sys.argv else ""
    base = os.path.basename(arg0)
    return base in ("arrayproc", "arrayproc.exe") or (
        base == "__main__.py" and os.path.basename(os.path.dirname(arg0)) == "arrayproc")
