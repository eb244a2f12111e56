"""The command line's logging: the package logs through Python logging (one logger per
module, under ``arrayproc``), and ``arrayproc`` shows those records on stderr.

Levels: ``-q`` warnings and errors only; by default also ``INFO`` (what a long command says
as it goes, e.g. each TMA window on a terminal); ``-v`` also ``DEBUG``. A record is one line,
``arrayproc: warning: …`` for warnings as for Python warnings, ``arrayproc: …`` for
information, ``arrayproc: debug: …`` for detail. The library alone configures nothing, as
the logging documentation asks of libraries: a program that imports arrayproc sees its
warnings through Python's last-resort handler and decides the rest.
"""

from __future__ import annotations

import logging
import sys
from collections.abc import Callable

LOGGER = "arrayproc"


class LineFormatter(logging.Formatter):
    """``arrayproc: [level: ]message`` on one line (the message's whitespace collapsed)."""

    def format(self, record: logging.LogRecord) -> str:
        text = " ".join(record.getMessage().split())
        if record.levelno >= logging.WARNING:
            return f"arrayproc: {record.levelname.lower()}: {text}"
        if record.levelno < logging.INFO:
            return f"arrayproc: debug: {text}"
        return f"arrayproc: {text}"


def level_of(quiet: bool = False, verbose: int = 0) -> int:
    """The logging level of ``-q`` (WARNING), of neither (INFO) or of ``-v`` (DEBUG)."""
    if quiet:
        return logging.WARNING
    return logging.DEBUG if verbose > 0 else logging.INFO


def configure(level: int) -> Callable[[], None]:
    """Send the package's records at ``level`` and above to stderr, one line each; returns
    the function that undoes it (the CLI calls it when the command ends)."""
    log = logging.getLogger(LOGGER)
    handler = logging.StreamHandler(_Stderr())
    handler.setFormatter(LineFormatter())
    old = (log.level, log.propagate)
    log.addHandler(handler)
    log.setLevel(level)
    log.propagate = False

    def restore() -> None:
        log.removeHandler(handler)
        log.setLevel(old[0])
        log.propagate = old[1]
    return restore


class _Stderr:
    """Whatever ``sys.stderr`` is when a record is written (tests replace it)."""

    def write(self, s: str) -> int:
        return sys.stderr.write(s)

    def flush(self) -> None:
        sys.stderr.flush()
