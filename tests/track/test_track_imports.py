"""Import structure of the tracking parts (state, models, filters, L-R, initialisation, runner):
no cycle between them (lazy imports included) and no import of stages, sim, plots or app from
any track module (docs/architecture.md). The whole package's cycles are tests/test_layers.py's."""

from __future__ import annotations

import grimp

from tests.test_layers import _cycles

FORBIDDEN = ("arrayproc.stages", "arrayproc.sim", "arrayproc.plots", "arrayproc.app")


PARTS = ("arrayproc.track.base", "arrayproc.track.state", "arrayproc.track.models",
         "arrayproc.track.filters", "arrayproc.track.manage.lr", "arrayproc.track.manage._kernels",
         "arrayproc.track.init", "arrayproc.track._kernels", "arrayproc.track.runner")


def _is_part(m: str) -> bool:
    return any(m == p or m.startswith(p + ".") for p in PARTS)


def _track_graph() -> tuple[grimp.ImportGraph, grimp.ImportGraph]:
    full = grimp.build_graph("arrayproc", cache_dir=None)
    g = grimp.ImportGraph()
    mods = [m for m in full.modules if _is_part(m)]
    for m in mods:
        g.add_module(m)
    for m in mods:
        for w in full.find_modules_directly_imported_by(m):
            if _is_part(w):
                g.add_import(importer=m, imported=w)
    return full, g


def test_no_cycle_inside_track_and_no_upward_import():
    full, g = _track_graph()
    assert _cycles(g) == []
    bad = [(m, w) for m in full.modules if m.startswith("arrayproc.track")
           for w in full.find_modules_directly_imported_by(m) if w.startswith(FORBIDDEN)]
    assert bad == []


def test_parts_import_downwards_only():
    """state ← models ← filters ← manage.lr ← runner: no part imports a later one."""
    full, _ = _track_graph()
    order = ["arrayproc.track.base", "arrayproc.track.state", "arrayproc.track.models",
             "arrayproc.track.filters", "arrayproc.track.manage.lr",
             "arrayproc.track.manage._kernels", "arrayproc.track.runner"]

    def rank(m: str) -> int | None:
        for i, p in enumerate(order):
            if m == p or m.startswith(p + "."):
                return i
        return None

    for m in full.modules:
        rm = rank(m)
        if rm is None or m.startswith("arrayproc.track.models.bearing_range_rate"):
            continue
        for w in full.find_modules_directly_imported_by(m):
            rw = rank(w)
            if rw is not None and "manage" not in m:
                assert rw <= rm, (m, w)
