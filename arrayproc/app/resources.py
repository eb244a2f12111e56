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

At run time, :mod:`arrayproc.chain.guard` covers every stage and tracker: a run whose
resident memory nears the limit stops cleanly, naming the stage.

It is an order-of-magnitude guard (the default limit is half the machine's RAM), not an
accounting: what it must catch are parameters such as 10⁸ beams that would exhaust the machine
before reading any data.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from typing import Any

from arrayproc.chain.guard import parse_bytes
from arrayproc.errors import ConfigError

__all__ = ["check_chain_memory", "default_limit", "estimate_chain_bytes", "machine_memory",
           "parse_bytes"]

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
