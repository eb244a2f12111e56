"""Resource guards: the working memory of a chain estimated from its parameters, before any
stage is built or any sample read, and refused above a limit (``--max-memory``).

The estimate counts the arrays that dominate a run (bytes, complex64 / float32 as the stages
use them), per stage:

* the reader: the HDF5 slab (at most 8 MiB) and three copies of a ``block`` × C block;
* a stage with beams (B beams, from ``beams = {count}`` or the bearing × elevation lists): the
  steering matrix B·F·C, the beam spectra B·F per snapshot kept for ``max(batch, snapshots)``
  snapshots, and the element spectra F·C per snapshot of a batch, F being the DFT bins in the
  stage's band (all ``nfft/2 + 1`` without one);
* any other stage: two copies of its input block.

It is an order-of-magnitude guard (the default limit is half the machine's RAM), not an
accounting: what it must catch are parameters such as 10⁸ beams that would exhaust the machine
before reading any data.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Mapping
from typing import Any

from arrayproc.errors import ConfigError

_UNITS = {"": 1, "b": 1, "k": 1 << 10, "kb": 1 << 10, "kib": 1 << 10, "m": 1 << 20,
          "mb": 1 << 20, "mib": 1 << 20, "g": 1 << 30, "gb": 1 << 30, "gib": 1 << 30,
          "t": 1 << 40, "tb": 1 << 40, "tib": 1 << 40}


def parse_bytes(text: str) -> float:
    """A size such as ``500M``, ``4G``, ``1.5GiB`` or ``1000000`` in bytes.

    Parameters
    ----------
    text : str
        Number with an optional unit (k, M, G, T; powers of 1024).

    Returns
    -------
    float
        Bytes (> 0).
    """
    m = re.fullmatch(r"\s*([0-9]*\.?[0-9]+(?:[eE][+-]?[0-9]+)?)\s*([A-Za-z]*)\s*", str(text))
    if not m or m.group(2).lower() not in _UNITS:
        raise ConfigError(f"--max-memory: expected a size such as 500M or 4G, got {text!r}")
    v = float(m.group(1)) * _UNITS[m.group(2).lower()]
    if not (math.isfinite(v) and v > 0):
        raise ConfigError(f"--max-memory: must be a finite size > 0, got {text!r}")
    return v


def machine_memory() -> float:
    """Physical memory of the machine, bytes (0 when unknown)."""
    try:
        return float(os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return 0.0


def default_limit() -> float:
    """Half the machine's RAM (8 GiB when it cannot be read), bytes."""
    ram = machine_memory()
    return ram / 2 if ram > 0 else float(8 << 30)


def _count(v: Any) -> int | None:
    """A non-negative integer count from a TOML value, else None (the validator reports it)."""
    if isinstance(v, bool):
        return None
    if isinstance(v, int) and v >= 0:
        return v
    if isinstance(v, float) and math.isfinite(v) and v >= 0:
        return int(math.ceil(v))
    return None


def _n_beams(beams: Any) -> int:
    if isinstance(beams, Mapping):
        if "count" in beams:
            return _count(beams["count"]) or 0
        n = 1
        for k in ("bearings", "elevations"):
            v = beams.get(k)
            if isinstance(v, list):
                n *= max(1, len(v))
        return n if ("bearings" in beams) else 0
    if isinstance(beams, list):
        return len(beams)
    return 0


def _bins(table: Mapping[str, Any], nfft: int, fs: float) -> int:
    full = nfft // 2 + 1
    band = table.get("band")
    if (isinstance(band, list) and len(band) == 2 and all(
            isinstance(b, (int, float)) and not isinstance(b, bool) for b in band)
            and fs > 0):
        lo, hi = max(0.0, float(band[0])), min(fs / 2, float(band[1]))
        if hi > lo:
            return min(full, int(math.ceil((hi - lo) / fs * nfft)) + 1)
    return full


def estimate_chain_bytes(config: Mapping[str, Any], n_channels: int, fs: float) -> list[
        tuple[str, float]]:
    """Estimated working memory of each part of a chain, from its parameters.

    Parameters
    ----------
    config : mapping
        The parsed chain TOML (``[input]``, ``[[stage]]``); malformed values are skipped (the
        chain validator reports them).
    n_channels : int
        Active channels of the recording.
    fs : float
        Sample rate of the recording, Hz (decimating stages are not followed: an upper bound).

    Returns
    -------
    list of (str, float)
        ``("reader", bytes)`` then ``(stage name, bytes)`` for each stage.
    """
    c = max(1, int(n_channels))
    inp = config.get("input", {})
    block = _count(inp.get("block", 8192)) if isinstance(inp, Mapping) else None
    block = block or 8192
    parts = [("reader", min(8 << 20, block * c * 4) + 3.0 * block * c * 4)]
    stages = config.get("stage", [])
    if not isinstance(stages, list):
        return parts
    for i, t in enumerate(stages):
        if not isinstance(t, Mapping):
            continue
        name = t.get("name") if isinstance(t.get("name"), str) else None
        name = name or (t.get("type") if isinstance(t.get("type"), str) else f"stage {i + 1}")
        nfft = _count(t.get("nfft", 0)) or block
        b = _n_beams(t.get("beams"))
        if b:
            f = _bins(t, nfft, fs)
            keep = max(_count(t.get("batch", 1)) or 1, _count(t.get("snapshots", 1)) or 1)
            parts.append((name, 8.0 * b * f * c + 8.0 * b * f * keep + 8.0 * f * c * keep))
        else:
            parts.append((name, 2.0 * 8.0 * max(block, nfft) * c))
    return parts


def _size(n: float) -> str:
    for unit, k in (("TiB", 1 << 40), ("GiB", 1 << 30), ("MiB", 1 << 20), ("KiB", 1 << 10)):
        if n >= k:
            return f"{n / k:.3g} {unit}"
    return f"{n:.0f} B"


def check_chain_memory(chain_path: str, config: Mapping[str, Any], n_channels: int, fs: float,
                       limit: float | None = None) -> float:
    """Refuse a chain whose estimated working memory exceeds ``limit`` bytes.

    Parameters
    ----------
    chain_path : str
        The chain file (named in the error).
    config : mapping
        The parsed chain TOML.
    n_channels : int
        Active channels.
    fs : float
        Sample rate, Hz.
    limit : float, optional
        Bytes (default :func:`default_limit`).

    Returns
    -------
    float
        The estimate, bytes.
    """
    limit = default_limit() if limit is None else float(limit)
    parts = estimate_chain_bytes(config, n_channels, fs)
    total = sum(b for _, b in parts)
    if total > limit:
        name, worst = max(parts, key=lambda p: p[1])
        raise ConfigError(f"{chain_path}: estimated working memory {_size(total)} exceeds the "
                          f"limit {_size(limit)} (largest: {name!r}, {_size(worst)}, for "
                          f"{n_channels} channels); reduce beams, nfft or batch, or raise "
                          "--max-memory")
    return total


# -- the memory guard at run time ---------------------------------------------------------------
_WHERE: list[str] = []  # the stages and trackers running now, innermost last


class running:  # noqa: N801 - used as a context manager, like contextlib's
    """Mark the stage or tracker ``name`` as running (a context manager): a memory error or
    the memory watchdog's stop inside names it (:func:`memory_error`)."""

    def __init__(self, name: str) -> None:
        self.name = str(name)

    def __enter__(self) -> running:
        _WHERE.append(self.name)
        return self

    def __exit__(self, *exc: object) -> None:
        if _WHERE and _WHERE[-1] == self.name:
            _WHERE.pop()
        elif self.name in _WHERE:
            _WHERE.remove(self.name)


def current_stage() -> str | None:
    """The innermost stage or tracker running now, else None."""
    return _WHERE[-1] if _WHERE else None


def memory_error(limit: float | None = None, used: float | None = None) -> Any:
    """The :class:`~arrayproc.errors.MemoryLimitError` of a run out of memory, naming the
    stage or tracker that was running."""
    from arrayproc.errors import MemoryLimitError
    where = current_stage()
    what = f"in {where}" if where else "before any stage ran"
    size = f" ({_size(used)} in use, limit {_size(limit)})" if used and limit else ""
    return MemoryLimitError(f"out of memory {what}{size}; stopped cleanly, nothing was "
                            "written (use a smaller block, fewer beams or channels, or give "
                            "more memory with --max-memory)")
