"""The curated public API: every name resolves, and public functions document their
parameters and results (numpydoc sections)."""

from __future__ import annotations

import inspect

import pytest

import arrayproc


@pytest.mark.parametrize("name", sorted(set(arrayproc.__all__) - {"__version__"}))
def test_every_public_name_resolves(name):
    assert getattr(arrayproc, name) is not None


@pytest.mark.parametrize("name", ["load_chain", "build_chain", "run_chain", "read_products",
                                  "simulate_file"])
def test_public_functions_have_numpydoc_sections(name):
    doc = inspect.getdoc(getattr(arrayproc, name)) or ""
    assert "Parameters\n----------" in doc and "Returns\n-------" in doc, name


def test_unknown_name_is_an_attribute_error():
    with pytest.raises(AttributeError):
        arrayproc.no_such_thing  # noqa: B018


def test_every_stage_type_is_exported():
    from arrayproc.chain import STAGES
    from arrayproc.stages import TYPES, load_all
    load_all()
    missing = {t: STAGES[t].__name__ for t in TYPES
               if getattr(arrayproc, STAGES[t].__name__, None) is not STAGES[t]}
    assert missing == {}


def test_every_model_filter_and_tma_method_is_exported():
    from arrayproc.track import batch, filters, models
    names = [n for mod in (models, filters, batch) for n in mod.__all__
             if not n.isupper() or n == "TDOA"]  # constants (Q1_PAPER, FILTERS) aside
    assert [n for n in names if n not in arrayproc.__all__] == []
    assert all(getattr(arrayproc, n) is getattr(m, n)
               for m in (models, filters, batch) for n in m.__all__ if n in arrayproc.__all__)


def test_load_chain_has_one_home():
    import arrayproc.chain
    import arrayproc.stages
    from arrayproc.app import api
    assert not hasattr(arrayproc.chain, "load_chain")
    assert arrayproc.load_chain is api.load_chain is arrayproc.stages.load_chain
    assert arrayproc.build_chain is api.build_chain is arrayproc.stages.build_chain


def test_api_run_chain_takes_the_engines_progress_callback(tmp_path, rng):
    import numpy as np

    from arrayproc.io.geometry import line_array
    from tests.conftest import write_recording
    rec = write_recording(tmp_path / "r.h5", rng.standard_normal((4096, 4)).astype(np.float32),
                          fs=1024.0, positions=line_array(4, 0.75))
    spec = arrayproc.build_chain('[input]\nblock = 1024\n[[stage]]\ntype = "power"\n'
                                 'band = [50.0, 400.0]\n')
    calls = []
    with arrayproc.Recording(rec) as r:
        n = arrayproc.run_chain(r, spec, progress=lambda d, t: calls.append((d, t)))
    assert n == 4 and len(calls) == 4 and calls[-1][0] == calls[-1][1]


def test_read_products_groups_by_kind(tmp_path):
    import numpy as np

    from arrayproc.errors import FormatError
    with arrayproc.ProductsWriter(tmp_path / "p.h5") as w:
        w.group("b1", "bearings")
        w.group("btr", "btr").append(time=np.arange(3.0), power_db=np.zeros((3, 2)))
        w.group("b2", "bearings")
    prod = arrayproc.read_products(tmp_path / "p.h5")
    assert list(prod.groups("bearings")) == ["b1", "b2"]
    assert list(prod.groups("btr")) == ["btr"] and prod.groups("tracks") == {}
    assert prod.groups("btr")["btr"].kind == "btr"
    assert prod.kinds() == ["bearings", "bearings", "btr"]  # HDF5 lists groups by name
    assert prod.root is prod["/"]
    with pytest.raises(FormatError, match="unknown product kind"):
        prod.groups("bearing")
