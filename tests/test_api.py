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
