"""Chain stages, in folders that follow the data path: ``condition`` (DFT filter), ``beamform``
(CBF, inverse beamforming, ETAM), ``passive`` (integration, BTR, LOFAR, bearings, line
contacts, band power),
``delay`` (transients, delays, TDOA localisation), ``active`` (ping beams, matched filter,
CFAR) and ``narrowband`` (EKF bearing/frequency tracker).

Each stage module registers its stage types when imported. :data:`TYPES` says which module
defines each chain ``type`` without importing anything, so a chain imports only the modules
of the stages it uses (:func:`load`); a test checks that it matches the registrations. The
engine (:mod:`arrayproc.chain`) knows none of them by name.
"""

from __future__ import annotations

import importlib
from collections.abc import Iterable

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
