"""Shared test helpers: small recordings written with the project's own writer."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from arrayproc.io.recording import RecordingWriter
from arrayproc.stages import load_all

load_all()  # register every stage type for chains built in the tests

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"
XAV = SHARED / "data" / "xav-large-array"


def write_recording(path: Path, data: np.ndarray, fs: float = 1000.0,
                    positions: np.ndarray | None = None, nav: dict | None = None,
                    chunk_samples: int | None = None, dtype=np.float32, **kw) -> Path:
    """Write samples (n, ch) as a recording file; returns the path."""
    n_ch = data.shape[1]
    if positions is None:
        positions = np.zeros((n_ch, 3))
        positions[:, 0] = -np.arange(n_ch) * 0.5
    with RecordingWriter(path, fs, n_ch, positions=positions, dtype=dtype,
                         chunk_samples=chunk_samples, **kw) as w:
        w.append(data)
        if nav is not None:
            w.set_nav(**nav)
    return path


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return f'"{v}"'
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {_toml_value(x)}" for k, x in v.items()) + " }"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    return repr(float(v)) if isinstance(v, float) else str(v)


def chain_toml(*stages: dict, block: int | None = None) -> str:
    """A chain file's text from stage tables, e.g. ``chain_toml(CBF_BEAMS, {"type": "btr"})``:
    the tests build their chains from these pieces instead of copying TOML strings."""
    out = [] if block is None else ["[input]", f"block = {block}"]
    for st in stages:
        out.append("[[stage]]")
        out += [f"{k} = {_toml_value(v)}" for k, v in st.items()]
    return "\n".join(out) + "\n"


def cbf_stage(nfft: int, band: list[float], count: int, **kw) -> dict:
    """A CBF stage table over cone angles 0-180 deg with a Hann taper (hop = nfft unless
    given)."""
    return {"type": "cbf", "nfft": nfft, "hop": kw.pop("hop", nfft), "window": "hann",
            "band": band, "beams": {"start": 0.0, "stop": 180.0, "count": count}, **kw}


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)
