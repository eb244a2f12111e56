"""The ``Examples`` sections of the curated API run as doctests, so they cannot go stale.

Every module that defines a name of ``arrayproc.__all__`` or of the main subpackages'
``__all__`` is searched; the curated names listed below must carry an example.
"""

from __future__ import annotations

import doctest
import importlib
import inspect

import pytest

import arrayproc
from arrayproc.app import api_docs

#: curated names that must show an example
WITH_EXAMPLES = ["Recording", "load_chain", "run_chain", "read_products", "CBF", "make_filter",
                 "arrayproc.track.batch.solve_bearings"]


def _modules() -> list[str]:
    mods = set()
    for _, names in api_docs.sections():
        for _, obj in names:
            mod = getattr(obj, "__module__", None)
            if mod and mod.startswith("arrayproc"):
                mods.add(mod)
    return sorted(mods)


#: Modules whose examples need an optional extra (the labelled extra needs Python >= 3.11).
NEEDS = {"arrayproc.io.labelled": "xarray"}


@pytest.mark.parametrize("module", _modules())
def test_examples_run(module):
    if module in NEEDS:  # examples of an optional extra's functions
        pytest.importorskip(NEEDS[module])
    mod = importlib.import_module(module)
    flags = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE
    result = doctest.testmod(mod, optionflags=flags, verbose=False, report=False)
    assert result.failed == 0, f"{module}: {result.failed} of {result.attempted} examples failed"


@pytest.mark.parametrize("name", WITH_EXAMPLES)
def test_curated_name_has_an_example(name):
    if name.startswith("arrayproc."):
        mod, _, attr = name.rpartition(".")
        obj = getattr(importlib.import_module(mod), attr)
    else:
        obj = getattr(arrayproc, name)
    doc = inspect.getdoc(obj) or ""
    assert "Examples\n--------" in doc and ">>> " in doc, name
    tests = doctest.DocTestFinder(recurse=False).find(obj, name)
    assert sum(len(t.examples) for t in tests) >= 3, name
