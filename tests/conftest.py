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


def _dask_scheduler():
    import sys
    dask = sys.modules.get("dask")
    return dask.config.get("scheduler", None) if dask is not None else None


_SCHEDULER_AT_MODULE_START: dict[str, object] = {}


def _module_of(item) -> str:
    return item.nodeid.split("::")[0]


@pytest.hookimpl(wrapper=True)
def pytest_runtest_setup(item):
    """Note dask's default scheduler before a module's first test sets anything up."""
    _SCHEDULER_AT_MODULE_START.setdefault(_module_of(item), _dask_scheduler())
    return (yield)


@pytest.hookimpl(wrapper=True)
def pytest_runtest_teardown(item, nextitem):
    """A module that leaves a different default dask scheduler behind (an unclosed
    ``distributed.Client``) fails at its last test's teardown, once every one of its fixtures
    is gone, not in whichever later test computes lazily. A hook rather than an autouse
    fixture: some pytest releases tear module fixtures down out of order."""
    result = yield
    name = _module_of(item)
    if nextitem is not None and _module_of(nextitem) == name:
        return
    before, after = _SCHEDULER_AT_MODULE_START.pop(name, None), _dask_scheduler()
    if after != before:
        import dask
        dask.config.set(scheduler=before)
        pytest.fail(f"{name} left dask's default scheduler at {after!r} (was {before!r})",
                    pytrace=False)
    return result
