"""Chain stages, in folders that follow the data path: ``condition`` (DFT filter), ``beamform``
(CBF, inverse beamforming, ETAM), ``passive`` (integration, BTR, LOFAR, bearings, line
contacts, band power),
``delay`` (transients, delays, TDOA localisation), ``active`` (ping beams, matched filter,
CFAR) and ``narrowband`` (EKF bearing/frequency tracker).

Each stage module registers its stage types when imported. :data:`TYPES` says which module
defines each chain ``type`` without importing anything, so a chain imports only the modules
of the stages it uses (:func:`load`); a test checks that it matches the registrations. The
engine (:mod:`arrayproc.chain`) knows none of them by name; :func:`load_chain` and
:func:`build_chain` here (``arrayproc.load_chain``, ``arrayproc.build_chain``) import the
modules of the stages a chain names, then build it with the engine.
"""

from __future__ import annotations

import importlib
from collections.abc import Iterable, Mapping
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from arrayproc.chain import ChainSpec

#: chain ``type`` -> module that registers it
TYPES: dict[str, str] = {
    "dft_filter": "arrayproc.stages.condition.dft_filter",
    "cbf": "arrayproc.stages.beamform.cbf",
    "cbf_azel": "arrayproc.stages.beamform.cbf_azel",
    "ibf": "arrayproc.stages.beamform.ibf",
    "psas": "arrayproc.stages.beamform.etam",
    "etam": "arrayproc.stages.beamform.etam",
    "integrate": "arrayproc.stages.passive.integrate",
    "btr": "arrayproc.stages.passive.btr",
    "lofar": "arrayproc.stages.passive.lofar",
    "bearings": "arrayproc.stages.passive.bearings",
    "lines": "arrayproc.stages.passive.lines",
    "power": "arrayproc.stages.passive.power",
    "pass": "arrayproc.stages.passive.power",
    "transients": "arrayproc.stages.delay.transients",
    "tde": "arrayproc.stages.delay.tde",
    "localise": "arrayproc.stages.delay.localise_stage",
    "active_beams": "arrayproc.stages.active.ping_beams",
    "matched_filter": "arrayproc.stages.active.matched_filter",
    "cfar": "arrayproc.stages.active.detect",
    "nb_ekf": "arrayproc.stages.narrowband.nb_ekf",
    "lr_cbf": "arrayproc.stages.beamform.lr_cbf",
    "mvdr": "arrayproc.stages.beamform.mvdr",
    "music": "arrayproc.stages.beamform.music",
    "beam_audio": "arrayproc.stages.beamform.beam_audio",
}


def load(types: Iterable[str]) -> None:
    """Import the modules that register these chain types (unknown types are left to the chain
    builder, which names them with the known ones)."""
    for t in set(types):
        if isinstance(t, str) and t in TYPES:
            importlib.import_module(TYPES[t])


def load_all() -> None:
    """Import every stage module, which registers every stage type."""
    for mod in sorted(set(TYPES.values())):
        importlib.import_module(mod)


def build_chain(config: Mapping[str, Any] | str, text: str = "") -> ChainSpec:
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
    from arrayproc.chain import build_chain as _build
    from arrayproc.chain import graph
    config, text = graph.parse_chain(config, text)
    load_types(config)
    return _build(config, text)


def load_chain(path: str) -> ChainSpec:
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
    from arrayproc.config import read_toml
    cfg, text = read_toml(path, "chain")
    return chain_from_toml(cfg, text, path)


def chain_from_toml(cfg: Mapping[str, Any], text: str, path: str) -> ChainSpec:
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
    from arrayproc.chain import build_chain as _build
    from arrayproc.errors import ConfigError
    load_types(cfg)
    try:
        return _build(cfg, text)
    except ConfigError as e:
        raise ConfigError(f"{path}: {e}") from None


def load_types(config: Any) -> None:
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
            load(types)


def markdown_table() -> str:
    """The stage-key table of docs/formats.md, made from the stages' declarations.

    Returns
    -------
    str
        A Markdown table: stage type (on its first row), key, type, default, unit and
        description, one row per key, the package's stage types (:data:`TYPES`) in
        alphabetical order.
    """
    from arrayproc.chain.stage import STAGES
    from arrayproc.config import markdown_header
    load_all()
    rows = markdown_header(True, "stage")
    for kind in sorted(TYPES):
        cls = STAGES[kind]
        if cls.params:
            rows.append(cls.params.markdown(first=kind))
        else:
            rows.append(f"| `{kind}` | (no keys) | | | | {cls.params.summary} |")
    return "\n".join(rows)
