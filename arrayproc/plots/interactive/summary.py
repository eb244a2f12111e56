"""Summary table of the report: per file, the recording it came from, the chain's stages,
the time span and the number of rows of every group, and what was counted (tracks,
contacts, solutions)."""

from __future__ import annotations

from typing import Any

import numpy as np

from arrayproc.io.text import as_text

#: The columns that carry a row's time, in the order they are looked for.
TIME_COLUMNS = ("time", "time_start", "t0")


def chain_stages(text: str) -> str:
    """The stage types of a chain (or tracker) configuration stored in a file's ``chain``
    attribute, in order, read with the package's one TOML parser."""
    from arrayproc.config import parse_toml
    from arrayproc.errors import ConfigError
    if not text.strip():
        return ""
    try:
        doc = parse_toml(text, "chain")
    except ConfigError:
        return "(unreadable chain text)"
    types = []
    for v in doc.values():
        items = v if isinstance(v, list) else [v]
        for it in items:
            if isinstance(it, dict) and "type" in it:
                types.append(str(it["type"]))
    return " → ".join(types)


def rows(files: list[tuple[str, Any]]) -> dict[str, list]:
    """One row per products group of each (path, ProductsFile): file, recording, chain,
    group, kind, rows, first and last time (s), duration (s) and what it counts."""
    out: dict[str, list] = {k: [] for k in ("file", "recording", "chain", "group", "kind",
                                            "rows", "t_first", "t_last", "duration", "counts")}
    from pathlib import Path
    for path, prod in files:
        root = prod.root
        rec = as_text(root.get("recording", "")) or as_text(root.get("source", ""))
        chain = chain_stages(as_text(root.get("chain", "")))
        for name, g in prod.items():
            if name == "/":
                continue
            tcol = next((c for c in TIME_COLUMNS if c in g), None)
            t = np.asarray(g[tcol], float).reshape(-1) if tcol else np.zeros(0)
            n = int(np.shape(g[tcol])[0]) if tcol else 0
            counts = ""
            if g.kind == "tracks" and "track_id" in g:
                counts = f"{np.unique(np.asarray(g['track_id'])).size} tracks"
            elif g.kind == "contacts" and "ping" in g:
                counts = f"{np.unique(np.asarray(g['ping'])).size} pings"
            elif g.kind == "tma":
                counts = f"{n} solution(s)"
            out["file"].append(Path(path).name)
            out["recording"].append(Path(rec).name if rec else "")
            out["chain"].append(chain)
            out["group"].append(name)
            out["kind"].append(g.kind)
            out["rows"].append(n)
            lo = float(np.nanmin(t)) if t.size else float("nan")
            hi = float(np.nanmax(t)) if t.size else float("nan")
            out["t_first"].append(lo)
            out["t_last"].append(hi)
            out["duration"].append(hi - lo if t.size else float("nan"))
            out["counts"].append(counts)
    return out


def summary_table(files: list[tuple[str, Any]]):
    """The summary as a Bokeh DataTable named ``summary``."""
    from bokeh.models import ColumnDataSource, DataTable, NumberFormatter, TableColumn
    data = rows(files)
    num = NumberFormatter(format="0.0")
    cols = [TableColumn(field="file", title="file", width=190),
            TableColumn(field="recording", title="recording", width=150),
            TableColumn(field="chain", title="chain (stages)", width=230),
            TableColumn(field="group", title="group", width=110),
            TableColumn(field="kind", title="kind", width=90),
            TableColumn(field="rows", title="rows", width=55),
            TableColumn(field="t_first", title="first (s)", formatter=num, width=65),
            TableColumn(field="t_last", title="last (s)", formatter=num, width=65),
            TableColumn(field="duration", title="span (s)", formatter=num, width=65),
            TableColumn(field="counts", title="counts", width=90)]
    return DataTable(source=ColumnDataSource(data, name="summary_source"), columns=cols,
                     width=1100, height=min(400, 28 + 26 * len(data["file"])),
                     name="summary", index_position=None)
