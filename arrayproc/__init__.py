"""arrayproc: hydrophone-array processing, from recordings to bearings, delays, contacts and
tracks.

The curated API (imported on first use, so ``import arrayproc`` stays cheap)::

    import arrayproc as ap
    chain = ap.load_chain("chain.toml")          # every stage type registered
    with ap.Recording("rec.h5") as rec, ap.ProductsWriter("out.h5") as out:
        ap.run_chain(rec, chain, out)
    groups = ap.read_products("out.h5")

Stage classes (``CBF``, ``DFTFilter``, ...), tracking components (``ConstantVelocity``,
``Bearing``, ``make_filter``) and the simulator (``simulate_file``) are reachable the same way;
the full list is ``arrayproc.__all__``.
"""

from __future__ import annotations

import importlib
from typing import Any

#: public name -> module that defines it
_API = {
    # chains
    "load_chain": "arrayproc.app.api",
    "build_chain": "arrayproc.app.api",
    "run_chain": "arrayproc.app.api",
    "Block": "arrayproc.chain.block",
    "Domain": "arrayproc.chain.domains",
    "Stage": "arrayproc.chain.stage",
    "Param": "arrayproc.config",
    # files
    "Recording": "arrayproc.io.recording",
    "RecordingWriter": "arrayproc.io.recording",
    "ProductsWriter": "arrayproc.io.products",
    "read_products": "arrayproc.io.products",
    # stages
    "DFTFilter": "arrayproc.stages.condition.dft_filter",
    "CBF": "arrayproc.stages.beamform.cbf",
    "IBF": "arrayproc.stages.beamform.ibf",
    "Integrate": "arrayproc.stages.passive.integrate",
    "BTR": "arrayproc.stages.passive.btr",
    "LOFAR": "arrayproc.stages.passive.lofar",
    "Bearings": "arrayproc.stages.passive.bearings",
    # simulation and tracking
    "simulate_file": "arrayproc.sim.run",
    "run_tracker": "arrayproc.track.runner",
    "make_filter": "arrayproc.track.filters",
    "ConstantVelocity": "arrayproc.track.models",
    "ConstantTurn": "arrayproc.track.models",
    "Bearing": "arrayproc.track.models",
    "ArrayprocError": "arrayproc.errors",
    "ConfigError": "arrayproc.errors",
    "FormatError": "arrayproc.errors",
}

#: public name -> module exposed whole
_MODULES = {"schema": "arrayproc.io.schema"}

__all__ = ["__version__", *_API, *_MODULES]


def _version() -> str:
    # Looked up on first use: importlib.metadata costs about a third of the start-up of
    # `arrayproc info` (docs/performance/startup.md).
    from importlib.metadata import PackageNotFoundError, version
    try:
        return version("arrayproc")
    except PackageNotFoundError:  # running from a source tree without installation
        return "0.0.0+unknown"


def __getattr__(name: str) -> Any:
    if name == "__version__":
        globals()[name] = v = _version()
        return v
    if name in _MODULES:
        value = importlib.import_module(_MODULES[name])
        globals()[name] = value
        return value
    mod = _API.get(name)
    if mod is None:
        raise AttributeError(f"module 'arrayproc' has no attribute {name!r}")
    value = getattr(importlib.import_module(mod), name, None)
    if value is None:
        raise AttributeError(f"arrayproc.{name}: not found in {mod}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(__all__)
