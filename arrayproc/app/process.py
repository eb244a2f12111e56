"""``arrayproc process``: one processing chain over one recording into a products file.

The chain's memory estimate is checked against the limit before any stage is built
(:mod:`arrayproc.app.resources`), the chain is validated before any data is read, and the
products file appears whole or not at all. Heavy modules load inside the function, so
importing this module stays cheap.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from arrayproc.app.progress import Echo, stderr_warning
from arrayproc.errors import ConfigError
from arrayproc.io.atomic import check_output


def process(recording: str, chain: str, output: str, positions: Any = None,
            nan: str = "error", progress: bool = False, max_memory: float | None = None,
            warn: Echo = stderr_warning, follow: bool = False, idle_s: float = 10.0,
            stats: list | None = None) -> int:
    """Run a processing chain over a recording into a products file.

    Parameters
    ----------
    recording : str
        Recording HDF5 file.
    chain : str
        Chain TOML file.
    output : str
        Products HDF5 file to write (atomically: it appears whole or not at all).
    positions : (n, 3) array, optional
        Geometry overriding or supplying the file's (m).
    nan : {"error", "zero"}
        NaN/Inf samples: stop, or replace by zeros with a warning.
    progress : bool
        Progress bar on stderr, in seconds of audio.
    max_memory : float, optional
        Refuse a chain whose estimated working memory exceeds this many bytes (default: half
        the machine's RAM).
    warn : callable
        Where warnings go.
    follow : bool
        The recording is still being written (HDF5 SWMR): process each block as soon as it
        is complete, write the products live (SWMR, readable while they grow) and stop after
        ``idle_s`` seconds without new samples or at a signal, leaving a complete file
        (:mod:`arrayproc.chain.follow`).
    idle_s : float
        See ``follow``.
    stats : list, optional
        Receives the :class:`arrayproc.chain.follow.FollowStats` of a followed run.

    Returns
    -------
    int
        Number of time blocks processed.
    """
    check_output(output, [recording, chain])
    if follow and not (math.isfinite(idle_s) and idle_s > 0):
        raise ConfigError(f"--idle must be a number of seconds > 0, got {idle_s}")
    from arrayproc.app.resources import check_chain_memory
    from arrayproc.config import read_toml
    from arrayproc.io.recording import Recording
    with Recording(recording, positions=positions, nan=nan, swmr=follow) as r:
        raw, text = read_toml(chain, "chain")  # read once
        # before any stage is built: parameters can ask for terabytes
        check_chain_memory(chain, raw, r.n_channels, r.fs, max_memory)
        from arrayproc.app.api import chain_from_toml, run_chain
        from arrayproc.io.products import ProductsWriter
        spec = chain_from_toml(raw, text, chain)  # validated before any data is read
        if follow:
            n = _follow(r, spec, recording, output, idle_s, warn, stats)
        else:
            with ProductsWriter(output, source=str(Path(recording).resolve()),
                                chain=spec.text) as out:
                n = run_chain(r, spec, out, progress=progress, log=warn)
        if r.n_nonfinite:
            warn(f"{recording}: {r.n_nonfinite} NaN/Inf samples replaced by zeros")
    return n


def _follow(r: Any, spec: Any, recording: str, output: str, idle_s: float, warn: Echo,
            stats: list | None) -> int:
    """``process --follow``: the live products file, stop requests ending the stream."""
    from arrayproc.chain.follow import follow_chain
    from arrayproc.io.atomic import set_graceful
    from arrayproc.io.products import ProductsWriter
    set_graceful(True)
    try:
        with ProductsWriter(output, source=str(Path(recording).resolve()), chain=spec.text,
                            live=True) as out:
            st = follow_chain(r, spec, out, idle_s=idle_s, log=warn)
    finally:
        set_graceful(False)
    if stats is not None:
        stats.append(st)
    return len(st.done)


def latency_line(st: Any) -> str:
    """One line: why a followed run ended and its block latencies (median, 95 %, max)."""
    import numpy as np
    lat = st.latencies()
    if lat.size == 0:
        return f"followed until {st.reason}; no block"
    q = np.percentile(lat, [50, 95])
    return (f"followed until {st.reason}; latency from a block's last sample to its products "
            f"on disk: median {q[0]:.3f} s, 95 % {q[1]:.3f} s, max {lat.max():.3f} s "
            f"({lat.size} blocks)")
