"""The unit of a recording's samples, carried to its products and to every level label.

A recording's ``/time_data`` attribute ``units`` says what one sample unit is: ``"Pa"``
(pascals: the simulator, or ``arrayproc import --scale``), ``"FS"`` (fraction of full scale:
``arrayproc import`` without ``--scale``); a file without the attribute is read as pascals. The
chain runner copies it to the products' root attribute ``units``. Levels are then dB re 1 µPa
only for pascals; for full-scale data the stages' default reference is full scale, and the
labels say dB re FS.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from arrayproc.io.text import as_text

PASCAL = "Pa"
FULL_SCALE = "FS"


def file_units(attrs: Mapping[str, Any]) -> str:
    """The ``units`` attribute of a recording's ``/time_data`` or a products file's root
    (``"Pa"`` when absent or empty: files written before the attribute existed)."""
    return as_text(attrs.get("units", PASCAL)).strip() or PASCAL


def recording_units(recording: Any) -> str:
    """The sample unit of an open recording (``"Pa"`` for objects that do not say)."""
    return str(getattr(recording, "units", PASCAL) or PASCAL)


def reference_amplitude(units: str, given: float | None = None) -> float:
    """Reference amplitude of a level in dB, in sample units: ``given`` when set, else 1 µPa
    (1e-6) for pascals and 1 (full scale, or one unit) otherwise."""
    if given is not None:
        return float(given)
    return 1e-6 if units == PASCAL else 1.0


def level_label(units: str, power: str = "") -> str:
    """``dB re 1 µPa`` for pascals, ``dB re FS`` for full scale, ``dB re 1 <unit>`` for any
    other unit; ``power`` is appended to the reference (``"²"``, ``"²/Hz"``)."""
    if units == PASCAL:
        return f"dB re 1 µPa{power}"
    if units == FULL_SCALE:
        return f"dB re FS{power}"
    return f"dB re 1 {units}{power}"
