"""The tracker types of a tracker TOML: ``[tracker] type = "single" | "multi" | "delays"``.

``type`` names the tracker explicitly. The older implicit form is still accepted and means the
same: no ``mode`` (or ``mode = "single"``) is ``type = "single"``, ``mode = "multi"`` is
``type = "multi"``, and ``mode = "multi"`` with ``measurements = "delays"`` is
``type = "delays"``. :func:`legacy_table` turns a table written either way into the implicit
form that the type's checker reads, so every checker accepts both.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from arrayproc.errors import ConfigError

#: tracker type -> what it tracks
TRACKER_TYPES: dict[str, str] = {
    "single": "one target from bearings (the L-R hypothesis bank; the papers' trackers)",
    "multi": "every target: the track manager over bearings, contacts or positions",
    "delays": "one source from hydrophone time delays (recursive TDOA position tracker)",
}


def tracker_type(t: Any, path: str = "tracker") -> str:
    """The type of a parsed ``[tracker]`` table, explicit or implicit ("single" if absent).

    Raises
    ------
    ConfigError
        An unknown type, or ``type`` given together with the older ``mode``.
    """
    if not isinstance(t, Mapping):
        return "single"
    if "type" in t:
        kind = t["type"]
        if kind not in TRACKER_TYPES:
            raise ConfigError(f"{path}: tracker.type must be one of "
                              f"{', '.join(TRACKER_TYPES)}, not {kind!r}")
        if "mode" in t:
            raise ConfigError(f"{path}: tracker.mode is the older form of tracker.type; give "
                              "only type")
        meas = t.get("measurements")
        if kind == "delays" and meas not in (None, "delays"):
            raise ConfigError(f"{path}: tracker.measurements must be 'delays' (or absent) for "
                              f"type = 'delays', not {meas!r}")
        if kind == "multi" and meas == "delays":
            raise ConfigError(f"{path}: the TDOA tracker is type = 'delays' (not type = 'multi' "
                              "with measurements = 'delays')")
        return str(kind)
    mode = t.get("mode", "single")
    if mode == "multi":
        return "delays" if t.get("measurements") == "delays" else "multi"
    return str(mode)  # "single", or a wrong mode for the single checker to name


def legacy_table(t: Any, path: str = "tracker") -> Any:
    """The ``[tracker]`` table in the implicit form (``mode``/``measurements``), unchanged
    when it has no ``type`` key."""
    if not isinstance(t, Mapping) or "type" not in t:
        return t
    kind = tracker_type(t, path)
    out = {k: v for k, v in t.items() if k != "type"}
    if kind in ("multi", "delays"):
        out["mode"] = "multi"
    if kind == "delays":
        out["measurements"] = "delays"
    return out
