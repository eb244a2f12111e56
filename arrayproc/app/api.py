"""The public API behind ``import arrayproc``: chains built with every stage type registered,
recordings and products opened in one call.

The engine (:mod:`arrayproc.chain`) knows no stage by name; this layer imports the modules of
the stages a chain names (:func:`arrayproc.stages.load`) before it is built.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from arrayproc import chain as _chain
from arrayproc.config import read_toml
from arrayproc.errors import ConfigError
from arrayproc.stages import TYPES, load_all
from arrayproc.stages import load as _load


def build_chain(config: Mapping[str, Any] | str, text: str = "") -> _chain.ChainSpec:
    """Build and validate a chain from a parsed TOML mapping or TOML text.

    Parameters
    ----------
    config : mapping or str
        The chain (``[input]`` and ``[[stage]]`` tables) or its TOML text.
    text : str
        The TOML text, kept in the products file for provenance.

    Returns
    -------
    ChainSpec
        The stages, validated before any data is read.
    """
    config, text = _chain.graph.parse_chain(config, text)
    _load_types(config)
    return _chain.build_chain(config, text)


def load_chain(path: str) -> _chain.ChainSpec:
    """Read and validate a chain TOML file (see :func:`build_chain`).

    Parameters
    ----------
    path : str
        Chain file.

    Returns
    -------
    ChainSpec

    Examples
    --------
    The shipped towed-array chain (``arrayproc data-dir`` prints the folder):

    >>> from arrayproc import load_chain
    >>> from arrayproc.data import data_path
    >>> chain = load_chain(str(data_path("chains/towed_passive.toml")))
    >>> chain.names()
    ['dft_filter', 'cbf', 'integrate', 'btr', 'lofar', 'bearings', 'lines']
    """
    cfg, text = read_toml(path, "chain")
    return chain_from_toml(cfg, text, path)


def chain_from_toml(cfg: Mapping[str, Any], text: str, path: str) -> _chain.ChainSpec:
    """Validate a chain file already parsed (:func:`arrayproc.config.read_toml`).

    Parameters
    ----------
    cfg : mapping
        The parsed TOML.
    text : str
        Its text (kept in the products file).
    path : str
        The file, for the messages.

    Returns
    -------
    ChainSpec
    """
    _load_types(cfg)
    try:
        return _chain.build_chain(cfg, text)
    except ConfigError as e:
        raise ConfigError(f"{path}: {e}") from None


def _load_types(config: Any) -> None:
    """Import only the stage modules the chain names (start-up stays short); when it names a
    type no module defines, import them all, so the chain builder's refusal lists every known
    type, not only those loaded so far."""
    tables = config.get("stage", []) if isinstance(config, Mapping) else []
    if isinstance(tables, list):
        types = [t.get("type") for t in tables
                 if isinstance(t, Mapping) and isinstance(t.get("type"), str)]
        if any(t not in TYPES for t in types):
            load_all()
        else:
            _load(types)


def run_chain(recording: Any, spec: _chain.ChainSpec, products: Any = None,
              t_start: float | None = None, t_stop: float | None = None,
              progress: bool = False, log: Callable[[str], None] | None = None) -> int:
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
    progress : bool
        Show a progress bar on stderr, in seconds of audio.
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
    from arrayproc.app.progress import audio_bar
    bar = audio_bar(progress, "process")
    try:
        return _chain.run_chain(recording, spec, products, t_start, t_stop, bar, log)
    finally:
        if bar is not None:
            bar.close()
