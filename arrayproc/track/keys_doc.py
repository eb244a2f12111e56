"""The key tables of the tracker and TMA files in docs/formats.md, made from their
declarations (a test keeps the doc equal to :func:`markdown_tables`)."""

from __future__ import annotations

from arrayproc.config import Schema


def markdown_tables() -> str:
    """One Markdown table per declared table of a tracker or TMA file.

    Returns
    -------
    str
        A ``####`` heading and a key table (key, type, default, unit, description) for the
        single-target ``[tracker]`` keys, the manager's, each multi-target sub-table,
        ``[tracker.delays]`` and ``[tma]``.
    """
    from arrayproc.track.batch.run import PARAMS as TMA_PARAMS
    from arrayproc.track.delays.config import DELAYS_PARAMS
    from arrayproc.track.multi.config import MANAGER_PARAMS, SUB_PARAMS
    from arrayproc.track.single import SINGLE_PARAMS
    tables: list[tuple[str, Schema]] = [
        ("`[tracker]`, `type = \"single\"` (also the TMA filter of `type = \"multi\"`)",
         SINGLE_PARAMS),
        ("`[tracker]`, `type = \"multi\"`: the track manager", MANAGER_PARAMS),
        *((f"`[tracker.{k}]`, `type = \"multi\"`", Schema(v)) for k, v in SUB_PARAMS.items()),
        ("`[tracker.delays]`, `type = \"delays\"`", DELAYS_PARAMS),
        ("`[tma]` (`arrayproc tma`)", TMA_PARAMS),
    ]
    return "\n\n".join(f"#### {title}\n\n{schema.markdown()}" for title, schema in tables)
