"""arrayproc: hydrophone-array processing, from recordings to bearings, delays, contacts and
tracks.

The curated API (imported on first use, so ``import arrayproc`` stays cheap)::

    import arrayproc as ap
    chain = ap.load_chain("chain.toml")          # every stage type registered
    with ap.Recording("rec.h5") as rec, ap.ProductsWriter("out.h5") as out:
        ap.run_chain(rec, chain, out)
    groups = ap.read_products("out.h5")

Every stage class (one per chain ``type``: ``CBF``, ``DFTFilter``, ``ETAM``, ``Cfar``, ...),
every motion and measurement model (``ConstantVelocity``, ``Bearing``, ``TDOA``, ...), every
filter (``EKF``, ``UKF``, ``RPF``, ... and ``make_filter``), every batch TMA method
(``solve_bearings``, ``solve_delays``, ``solve_compact``, ...), the products reader
(``read_products`` -> ``ProductsFile`` with ``.groups(kind)``; ``open_products`` and
``open_recording`` -> xarray datasets and pandas tables), the plots (``plot_file`` and
the ``draw_*`` functions that draw on a matplotlib ``Axes``) and the simulator
(``simulate_file``) are reachable the same way; the full list is ``arrayproc.__all__``. Each
name is defined once: each ``arrayproc`` attribute is the object of the module listed in ``_API``.
"""

from __future__ import annotations

import importlib
from typing import Any

#: public name -> module that defines it
_API = {
    # chains
    "load_chain": "arrayproc.app.api",
    "build_chain": "arrayproc.app.api",
    "chain_from_toml": "arrayproc.app.api",
    "run_chain": "arrayproc.app.api",
    "Block": "arrayproc.chain.block",
    "Domain": "arrayproc.chain.domains",
    "Stage": "arrayproc.chain.stage",
    "Param": "arrayproc.config",
    # files
    "Recording": "arrayproc.io.recording",
    "RecordingWriter": "arrayproc.io.recording",
    "ProductsWriter": "arrayproc.io.products",
    "ProductsFile": "arrayproc.io.products",
    "ProductGroup": "arrayproc.io.products",
    "read_products": "arrayproc.io.products",
    "open_products": "arrayproc.io.labelled",
    "open_recording": "arrayproc.io.labelled",
    # stages: one class per chain type (arrayproc.stages.TYPES; a test keeps them equal)
    "DFTFilter": "arrayproc.stages.condition.dft_filter",
    "CBF": "arrayproc.stages.beamform.cbf",
    "CBFAzEl": "arrayproc.stages.beamform.cbf_azel",
    "IBF": "arrayproc.stages.beamform.ibf",
    "PSAS": "arrayproc.stages.beamform.etam",
    "ETAM": "arrayproc.stages.beamform.etam",
    "Integrate": "arrayproc.stages.passive.integrate",
    "BTR": "arrayproc.stages.passive.btr",
    "LOFAR": "arrayproc.stages.passive.lofar",
    "Bearings": "arrayproc.stages.passive.bearings",
    "Lines": "arrayproc.stages.passive.lines",
    "Power": "arrayproc.stages.passive.power",
    "PassThrough": "arrayproc.stages.passive.power",
    "Transients": "arrayproc.stages.delay.transients",
    "Tde": "arrayproc.stages.delay.tde",
    "Localise": "arrayproc.stages.delay.localise_stage",
    "ActiveBeams": "arrayproc.stages.active.ping_beams",
    "MatchedFilter": "arrayproc.stages.active.matched_filter",
    "Cfar": "arrayproc.stages.active.detect",
    "NarrowbandEKFStage": "arrayproc.stages.narrowband.nb_ekf",
    "LRCBF": "arrayproc.stages.beamform.lr_cbf",
    "MVDR": "arrayproc.stages.beamform.mvdr",
    "MUSIC": "arrayproc.stages.beamform.music",
    "BeamAudio": "arrayproc.stages.beamform.beam_audio",
    # simulation
    "simulate_file": "arrayproc.sim.run",
    # tracking: runners, models, filters
    "run_tracker": "arrayproc.track.runner",
    "load_tracker_config": "arrayproc.track.runner",
    "MotionModel": "arrayproc.track.models",
    "MeasurementModel": "arrayproc.track.models",
    "ConstantVelocity": "arrayproc.track.models",
    "ConstantTurn": "arrayproc.track.models",
    "make_model": "arrayproc.track.models",
    "Bearing": "arrayproc.track.models",
    "MirroredBearing": "arrayproc.track.models",
    "LevelBearing": "arrayproc.track.models",
    "TDOA": "arrayproc.track.models",
    "Filter": "arrayproc.track.filters",
    "FilterDivergence": "arrayproc.track.filters",
    "GaussianFilter": "arrayproc.track.filters",
    "EKF": "arrayproc.track.filters",
    "UKF": "arrayproc.track.filters",
    "CKF": "arrayproc.track.filters",
    "GHF": "arrayproc.track.filters",
    "SRF": "arrayproc.track.filters",
    "RPF": "arrayproc.track.filters",
    "FILTERS": "arrayproc.track.filters",
    "make_filter": "arrayproc.track.filters",
    # batch TMA: one solver per method, the driver, the solution
    "solve_bearings": "arrayproc.track.batch",
    "solve_line_bearings": "arrayproc.track.batch",
    "solve_delays": "arrayproc.track.batch",
    "solve_compact": "arrayproc.track.batch",
    "solve_cross_fix": "arrayproc.track.batch",
    "TmaSolution": "arrayproc.track.batch",
    "run_tma": "arrayproc.track.batch.run",
    # plots: file writing, and drawing on a matplotlib Axes
    "plot_file": "arrayproc.plots",
    "draw_btr": "arrayproc.plots.btr",
    "draw_lofar": "arrayproc.plots.lofar",
    "draw_track": "arrayproc.plots.track",
    "draw_tma": "arrayproc.plots.tma",
    "draw_metrics": "arrayproc.plots.metrics",
    "draw_contacts": "arrayproc.plots.contacts",
    "draw_range_doppler": "arrayproc.plots.range_doppler",
    "draw_delays": "arrayproc.plots.delays",
    "draw_detections": "arrayproc.plots.detections",
    "draw_positions": "arrayproc.plots.positions",
    "draw_nb_tracks": "arrayproc.plots.nb_tracks",
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
