"""The memory guard at run time: which stage or tracker is running, and a watchdog that stops
the run cleanly when the process nears its memory limit, naming it.

The chain's estimate (:mod:`arrayproc.app.resources`) refuses parameters before any stage is
built; this module covers what the estimate does not see (every stage and tracker, the data
itself):

* :func:`named` wraps each stage's generator (:func:`arrayproc.chain.graph.compose`) and
  :class:`running` marks a tracker or TMA solver, so that a ``MemoryError`` raised inside
  (an allocation above the process's ``RLIMIT_AS`` / ``RLIMIT_DATA``, numpy's or numba's)
  becomes :class:`~arrayproc.errors.MemoryLimitError` naming the stage;
* :class:`MemoryWatch`, a thread sampling the resident memory every 50 ms, asks the run to
  stop (:func:`arrayproc.io.atomic.request_error`) when it exceeds the limit: the next write,
  or the next block of any stage, raises the same error, the temporary output is removed and
  the command exits with :data:`arrayproc.errors.EXIT_MEMORY`.

The limit (:func:`run_limit`): ``--max-memory`` or ``ARRAYPROC_MAX_MEMORY`` when given, else
90 % of the tightest of the machine's RAM, the cgroup's memory limit and the process's
``RLIMIT_AS``/``RLIMIT_DATA`` — below where the system would kill the process.
"""

from __future__ import annotations

import math
import os
import re
import threading
from collections.abc import Iterable, Iterator
from typing import Any

from arrayproc.errors import ConfigError, MemoryLimitError
from arrayproc.io.atomic import check_stop, request_error

#: Environment variable giving the memory limit (``500M``, ``4G``), as ``--max-memory``.
ENV = "ARRAYPROC_MAX_MEMORY"

_WHERE: list[str] = []  # the stages and trackers running now, innermost last


class running:  # noqa: N801 - a context manager, named like contextlib's
    """Mark the stage or tracker ``name`` as running: a memory error or the watchdog's stop
    inside names it (:func:`memory_error`)."""

    def __init__(self, name: str) -> None:
        self.name = str(name)

    def __enter__(self) -> running:
        _WHERE.append(self.name)
        return self

    def __exit__(self, exc_type: Any, exc: Any, tb: Any) -> None:
        if exc_type is not None and issubclass(exc_type, MemoryError):
            err = memory_error()
            _pop(self.name)
            raise err from None
        _pop(self.name)


def _pop(name: str) -> None:
    if _WHERE and _WHERE[-1] == name:
        _WHERE.pop()
    elif name in _WHERE:
        _WHERE.remove(name)


def named(name: str, blocks: Iterable[Any]) -> Iterator[Any]:
    """The items of a stage's generator, with the stage marked as running while it computes
    each one; a pending stop (a write failure, the watchdog) is raised between items."""
    it = iter(blocks)
    label = f"stage {name!r}"
    while True:
        _WHERE.append(label)
        try:
            item = next(it)
        except StopIteration:
            return
        except MemoryError:
            raise memory_error() from None
        finally:
            _pop(label)
        check_stop()
        yield item


def current_stage() -> str | None:
    """The innermost stage or tracker running now, else None."""
    return _WHERE[-1] if _WHERE else None


def _size(n: float) -> str:
    for unit, k in (("TiB", 1 << 40), ("GiB", 1 << 30), ("MiB", 1 << 20), ("KiB", 1 << 10)):
        if n >= k:
            return f"{n / k:.3g} {unit}"
    return f"{n:.0f} B"


def memory_error(limit: float | None = None, used: float | None = None) -> MemoryLimitError:
    """The error of a run out of memory, naming the stage or tracker that was running."""
    where = current_stage()
    what = f"in {where}" if where else "outside any stage"
    size = f" ({_size(used)} resident, limit {_size(limit)})" if used and limit else ""
    return MemoryLimitError(f"out of memory {what}{size}; stopped cleanly, nothing was "
                            "written (use a smaller block, fewer beams or channels, or give "
                            "more memory with --max-memory)")


# -- the limit and the watchdog -------------------------------------------------------------
_UNITS = {"": 1, "b": 1, "k": 1 << 10, "kb": 1 << 10, "kib": 1 << 10, "m": 1 << 20,
          "mb": 1 << 20, "mib": 1 << 20, "g": 1 << 30, "gb": 1 << 30, "gib": 1 << 30,
          "t": 1 << 40, "tb": 1 << 40, "tib": 1 << 40}


def parse_bytes(text: str, what: str = "--max-memory") -> float:
    """A size such as ``500M``, ``4G``, ``1.5GiB`` or ``1000000`` in bytes.

    Parameters
    ----------
    text : str
        Number with an optional unit (k, M, G, T; powers of 1024).
    what : str
        The option or variable it came from (named in the error).

    Returns
    -------
    float
        Bytes (> 0).
    """
    m = re.fullmatch(r"\s*([0-9]*\.?[0-9]+(?:[eE][+-]?[0-9]+)?)\s*([A-Za-z]*)\s*", str(text))
    if not m or m.group(2).lower() not in _UNITS:
        raise ConfigError(f"{what}: expected a size such as 500M or 4G, got {text!r}")
    v = float(m.group(1)) * _UNITS[m.group(2).lower()]
    if not (math.isfinite(v) and v > 0):
        raise ConfigError(f"{what}: must be a finite size > 0, got {text!r}")
    return v


def resident_bytes() -> float:
    """The process's resident memory, bytes (0 when unknown)."""
    try:
        with open("/proc/self/statm", "rb") as fh:
            return float(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError, AttributeError):
        return 0.0


def system_limit() -> float:
    """The tightest of the machine's RAM, the cgroup's memory limit and the process's
    address-space and data limits, bytes (inf when none is known)."""
    found = []
    try:
        found.append(float(os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")))
    except (ValueError, OSError, AttributeError):
        pass
    for p in ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"):
        try:
            v = open(p).read().strip()
        except OSError:
            continue
        if v.isdigit() and int(v) < 1 << 60:
            found.append(float(v))
    try:
        import resource
        for r in (resource.RLIMIT_AS, getattr(resource, "RLIMIT_DATA", None)):
            if r is not None:
                soft = resource.getrlimit(r)[0]
                if soft != resource.RLIM_INFINITY and soft > 0:
                    found.append(float(soft))
    except ImportError:
        pass
    return min(found) if found else float("inf")


def run_limit(max_memory: float | None = None) -> float:
    """The resident-memory limit of a run, bytes: ``max_memory``, else
    ``ARRAYPROC_MAX_MEMORY``, else 90 % of :func:`system_limit`."""
    if max_memory is not None:
        return float(max_memory)
    text = os.environ.get(ENV, "").strip()
    if text:
        return parse_bytes(text, ENV)
    return 0.9 * system_limit()


class MemoryWatch:
    """A daemon thread that requests a clean stop when the resident memory exceeds
    ``limit`` bytes (a context manager; nothing runs for an infinite limit)."""

    def __init__(self, limit: float, interval: float = 0.05) -> None:
        self.limit = float(limit)
        self.interval = float(interval)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.peak = 0.0

    def _watch(self) -> None:
        while not self._stop.wait(self.interval):
            used = resident_bytes()
            self.peak = max(self.peak, used)
            if used > self.limit:
                request_error(memory_error(self.limit, used))
                return

    def __enter__(self) -> MemoryWatch:
        if self.limit < float("inf"):
            self._thread = threading.Thread(target=self._watch, name="arrayproc-memory",
                                            daemon=True)
            self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(1.0)
