"""docs/api.md is the reference generated from the curated API (regenerate it with
``python scripts/make_api_docs.py``)."""

from __future__ import annotations

from pathlib import Path

from arrayproc.app import api_docs

API_MD = Path(__file__).resolve().parents[1] / "docs" / "api.md"


def test_committed_reference_equals_the_generated_one():
    assert API_MD.read_text() == api_docs.markdown(), \
        "docs/api.md is out of date: run python scripts/make_api_docs.py"


def test_reference_lists_every_curated_name():
    text = API_MD.read_text()
    for pkg, names in api_docs.sections():
        assert f"## `{pkg}`" in text
        for name, _ in names:
            assert f"### `{name}`" in text, f"{pkg}.{name}"


def test_subpackages_with_a_curated_list_are_found():
    pkgs = api_docs.curated_packages()
    assert {"arrayproc.chain", "arrayproc.track.models", "arrayproc.track.filters",
            "arrayproc.track.batch"} <= set(pkgs)
    assert "arrayproc" not in pkgs
