"""``arrayproc process``: one processing chain over one recording into a products file.

The chain's memory estimate is checked against the limit before any stage is built
(:mod:`arrayproc.app.resources`), the chain is validated before any data is read, and the
products file appears whole or not at all. Heavy modules load inside the function, so
importing this module stays cheap.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from arrayproc.app.progress import Echo, stderr_warning
from arrayproc.io.atomic import check_output


def process(recording: str, chain: str, output: str, positions: Any = None,
            nan: str = "error", progress: bool = False, max_memory: float | None = None,
            warn: Echo = stderr_warning) -> int:
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

    Returns
    -------
    int
        Number of time blocks processed.
    """
    check_output(output, [recording, chain])
    from arrayproc.app.resources import check_chain_memory
    from arrayproc.config import tomllib
    from arrayproc.io.recording import Recording
    try:
        with open(chain, "rb") as fh:
            raw = tomllib.loads(fh.read().decode())
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
        raw = None  # load_chain below names the problem
    with Recording(recording, positions=positions, nan=nan) as r:
        if raw is not None:  # before any stage is built: parameters can ask for terabytes
            check_chain_memory(chain, raw, r.n_channels, r.fs, max_memory)
        from arrayproc.app.api import load_chain, run_chain
        from arrayproc.io.products import ProductsWriter
        spec = load_chain(chain)  # validated before any data is read
        with ProductsWriter(output, source=str(Path(recording).resolve()),
                            chain=spec.text) as out:
            n = run_chain(r, spec, out, progress=progress, log=warn)
        if r.n_nonfinite:
            warn(f"{recording}: {r.n_nonfinite} NaN/Inf samples replaced by zeros")
    return n
