"""docs/formats.md's tracker and TMA key tables are the declarations' own
(``arrayproc.track.keys_doc.markdown_tables``)."""

from pathlib import Path

from arrayproc.track.keys_doc import markdown_tables
from arrayproc.track.single import SINGLE_PARAMS

DOC = Path(__file__).resolve().parents[2] / "docs" / "formats.md"
BEGIN, END = "<!-- tracker keys: begin (generated) -->\n", "\n<!-- tracker keys: end -->"


def test_formats_doc_holds_the_generated_tables():
    text = DOC.read_text(encoding="utf-8")
    held = text[text.index(BEGIN) + len(BEGIN):text.index(END)]
    assert held == markdown_tables(), (
        "docs/formats.md's tracker key tables differ from the declarations; regenerate them "
        "with `python -c 'from arrayproc.track.keys_doc import markdown_tables; "
        "print(markdown_tables())'`")


def test_every_single_tracker_key_is_listed():
    tables = markdown_tables()
    for k in SINGLE_PARAMS:
        assert f"| `{k}` |" in tables
