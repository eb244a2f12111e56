"""Shared test helpers: small recordings written with the project's own writer."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from arrayproc.evaluate.chains import cbf_stage, chain_toml  # noqa: F401  (the tests' import point)
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


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)


@pytest.fixture(autouse=True, scope="module")
def dask_scheduler_unchanged(request):
    """A module that leaves a different default dask scheduler behind (an unclosed
    ``distributed.Client``) fails here, not in whichever later test computes lazily."""
    import sys

    def scheduler():
        dask = sys.modules.get("dask")
        return dask.config.get("scheduler", None) if dask is not None else None

    before = scheduler()
    yield
    after = scheduler()
    if after != before:
        import dask
        dask.config.set(scheduler=before)
        pytest.fail(f"{request.module.__name__} left dask's default scheduler at {after!r} "
                    f"(was {before!r})", pytrace=False)
