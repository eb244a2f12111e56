"""The public API behind ``import arrayproc``: chains built with every stage type registered,
recordings and products opened in one call.

The engine (:mod:`arrayproc.chain`) knows no stage by name; :func:`load_chain` and
:func:`build_chain` (defined in :mod:`arrayproc.stages`, the layer that knows the stage
modules, so that the evaluation layer uses the same ones) import the modules of the stages a
chain names before it is built. A chain file is read only there (the engine builds from
mappings). ``build_chain`` and ``run_chain`` do what the engine's functions of the same names
do, for any chain, plus the stage imports and the progress bar.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from arrayproc import chain as _chain
from arrayproc.stages import build_chain, chain_from_toml, load_chain

__all__ = ["build_chain", "chain_from_toml", "load_chain", "run_chain"]


def run_chain(recording: Any, spec: _chain.ChainSpec, products: Any = None,
              t_start: float | None = None, t_stop: float | None = None,
              progress: bool | Callable[[float, float], None] = False,
              log: Callable[[str], None] | None = None) -> int:
    """Run a chain over a recording (see :func:`arrayproc.chain.run_chain`).

    Parameters
    ----------
    recording : Recording
        The open recording.
    spec : ChainSpec
        A chain from :func:`load_chain` or :func:`build_chain`.
    products : ProductsWriter, optional
        Where the stages write their products.
    t_start, t_stop : float, optional
        Segment to process, s since the recording start.
    progress : bool or callable
        True: a progress bar on stderr, in seconds of audio; a callable
        ``progress(done_s, total_s)`` is called after each block instead (what the engine,
        :func:`arrayproc.chain.run_chain`, takes).
    log : callable, optional
        Where stages send warnings (default: stderr).

    Returns
    -------
    int
        Number of time blocks read.

    Examples
    --------
    Band power of a 100 Hz tone on four hydrophones, one products row per 1000-sample block:

    >>> import os, tempfile
    >>> import numpy as np
    >>> import arrayproc as ap
    >>> tmp = tempfile.TemporaryDirectory()
    >>> rec_path, out_path = (os.path.join(tmp.name, n) for n in ("rec.h5", "products.h5"))
    >>> positions = np.zeros((4, 3)); positions[:, 0] = -0.75 * np.arange(4)
    >>> tone = np.sin(2 * np.pi * 100.0 * np.arange(4000) / 1000.0)
    >>> with ap.RecordingWriter(rec_path, 1000.0, 4, positions=positions) as w:
    ...     w.append(np.repeat(tone[:, None], 4, axis=1).astype(np.float32))
    >>> chain = ap.build_chain('''
    ... [input]
    ... block = 1000
    ... [[stage]]
    ... type = "power"
    ... band = [50.0, 200.0]
    ... ''')
    >>> with ap.Recording(rec_path) as rec, ap.ProductsWriter(out_path) as products:
    ...     ap.run_chain(rec, chain, products)
    4
    >>> ap.read_products(out_path)["power"]["time"]
    array([0.5, 1.5, 2.5, 3.5])
    >>> tmp.cleanup()
    """
    if callable(progress):
        return _chain.run_chain(recording, spec, products, t_start, t_stop, progress, log)
    from arrayproc.app.progress import audio_bar
    bar = audio_bar(progress, "process")
    try:
        return _chain.run_chain(recording, spec, products, t_start, t_stop, bar, log)
    finally:
        if bar is not None:
            bar.close()
