"""docs/formats.md's scenario key table is the declarations' own
(``arrayproc.sim.scenario_keys.markdown_tables``), and every shipped scenario reads through
them."""

from pathlib import Path

import pytest

from arrayproc.config import Section
from arrayproc.errors import ConfigError
from arrayproc.sim.scenario_keys import SCENARIO, SECTIONS, markdown_tables

DOC = Path(__file__).resolve().parents[2] / "docs" / "formats.md"
BEGIN, END = "<!-- scenario keys: begin (generated) -->\n", "\n<!-- scenario keys: end -->"


def test_formats_doc_holds_the_generated_table():
    text = DOC.read_text(encoding="utf-8")
    held = text[text.index(BEGIN) + len(BEGIN):text.index(END)]
    assert held == markdown_tables(), (
        "docs/formats.md's scenario key table differs from the declarations; regenerate it "
        "with `python -c 'from arrayproc.sim.scenario_keys import markdown_tables; "
        "print(markdown_tables())'`")


def test_every_key_is_documented_with_a_unit_or_a_kind_that_needs_none():
    for heading, schema in SECTIONS:
        for key, p in schema.items():
            assert p.doc, f"{heading} {key} has no doc"
            if p.kind == "float" and not p.unit:
                pytest.fail(f"{heading} {key} is a number without a unit")


def test_every_nested_table_declares_its_keys():
    seen = set()

    def walk(schema):
        for key, p in schema.items():
            if p.kind in ("table", "tables") or p.schema is not None:
                if key not in ("waveforms",):
                    assert p.schema is not None, key
                if p.schema is not None and id(p.schema) not in seen:
                    seen.add(id(p.schema))
                    walk(p.schema)

    walk(SCENARIO)
    assert {id(s) for _, s in SECTIONS} >= seen


def test_section_names_table_and_key_in_one_line():
    with pytest.raises(ConfigError, match=r"^s\.toml: \[recording\] fs: must be > 0, got -1\.0$"):
        Section({"fs": -1.0, "duration": 1.0}, SECTIONS[0][1], "recording", "s.toml")
    with pytest.raises(ConfigError, match=r"^s\.toml: \[recording\]: unknown key 'fz'"):
        Section({"fz": 1.0}, SECTIONS[0][1], "recording", "s.toml")
    with pytest.raises(ConfigError, match=r"^s\.toml: \[recording\] duration: missing"):
        Section({"fs": 1.0}, SECTIONS[0][1], "recording", "s.toml")
