"""docs/formats.md's stage-key table is the stages' own declarations
(``arrayproc.stages.markdown_table``), so no key goes undocumented."""

import re
from pathlib import Path

from arrayproc.chain.stage import STAGES
from arrayproc.config import Param, Schema
from arrayproc.stages import TYPES, load_all, markdown_table

DOC = Path(__file__).resolve().parents[2] / "docs" / "formats.md"
BEGIN, END = "<!-- stage keys: begin (generated) -->\n", "\n<!-- stage keys: end -->"


def test_formats_doc_holds_the_generated_table():
    text = DOC.read_text(encoding="utf-8")
    held = text[text.index(BEGIN) + len(BEGIN):text.index(END)]
    assert held == markdown_table(), (
        "docs/formats.md's stage-key table differs from the declarations; regenerate it with "
        "`python -c 'from arrayproc.stages import markdown_table; print(markdown_table())'`")


def test_table_lists_every_type_and_key():
    load_all()
    table = markdown_table()
    kind = None
    seen: dict[str, list[str]] = {}
    for line in table.splitlines()[2:]:
        m = re.match(r"^\| (?:`(\w+)`)? \| `(\w+)` \|", line)
        if m is None:
            continue
        kind = m.group(1) or kind
        seen.setdefault(kind, []).append(m.group(2))
    for k in TYPES:
        assert seen.get(k, []) == list(STAGES[k].params), k


def test_markdown_row_has_type_default_unit_doc():
    s = Schema({"band": Param("band", None, "[lo, hi] kept", unit="Hz"),
                "mode": Param("str", "a", "a or b", choices=("a", "b")),
                "n": Param("int", doc="count")})
    lines = s.markdown().splitlines()
    assert lines[0] == "| key | type | default | unit | description |"
    assert lines[2] == "| `band` | [lo, hi] | — | Hz | [lo, hi] kept |"
    assert lines[3] == '| `mode` | "a" \\| "b" | "a" | — | a or b |'
    assert lines[4] == "| `n` | int | required | — | count |"
