"""Chain files built from stage tables, for the scenarios, scripts and tests.

``chain_toml(cbf_stage(...), {"type": "btr"})`` writes the text of a chain file, so that the
set-ups build their chains from these pieces instead of copying TOML strings. Hand-written
rather than a TOML writer library: the chains need only flat stage tables with inline values,
and the text must stay byte-for-byte what the chains' ``text`` attribute records.
"""

from __future__ import annotations

from typing import Any

__all__ = ["chain_toml", "cbf_stage", "toml_value"]


def toml_value(v: Any) -> str:
    """One value as an inline TOML value (floats by ``repr``, numpy scalars included)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return f'"{v}"'
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {toml_value(x)}" for k, x in v.items()) + " }"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    return repr(float(v)) if isinstance(v, float) else str(v)


def chain_toml(*stages: dict, block: int | None = None) -> str:
    """A chain file's text from stage tables, e.g. ``chain_toml(CBF_BEAMS, {"type": "btr"})``,
    with ``[input] block`` when ``block`` is given."""
    out = [] if block is None else ["[input]", f"block = {block}"]
    for st in stages:
        out.append("[[stage]]")
        out += [f"{k} = {toml_value(v)}" for k, v in st.items()]
    return "\n".join(out) + "\n"


def cbf_stage(nfft: int, band: list[float], count: int, **kw: Any) -> dict:
    """A CBF stage table over cone angles 0-180 deg with a Hann taper (hop = nfft unless
    given)."""
    return {"type": "cbf", "nfft": nfft, "hop": kw.pop("hop", nfft), "window": "hann",
            "band": band, "beams": {"start": 0.0, "stop": 180.0, "count": count}, **kw}
