"""docs/formats.md's products table is the schema's own (``arrayproc.io.schema``)."""

from pathlib import Path

from arrayproc.io.schema import KINDS, markdown_table

DOC = Path(__file__).resolve().parents[2] / "docs" / "formats.md"


def test_formats_doc_holds_the_schema_table():
    table = markdown_table()
    assert table in DOC.read_text(encoding="utf-8"), (
        "docs/formats.md's products table differs from the schema; regenerate it with "
        "`python -c 'from arrayproc.io.schema import markdown_table; print(markdown_table())'`")


def test_table_lists_every_kind_and_column():
    table = markdown_table()
    for name, k in KINDS.items():
        line = next(x for x in table.splitlines() if x.startswith(f"| `{name}` |"))
        for col, c in k.columns.items():
            assert (f"`{col}`" if c.required else f"*`{col}`*") in line
