"""Dask clients of one and of two local workers for the evaluation tests."""

from __future__ import annotations

import pytest


@pytest.fixture(scope="module")
def clients():
    pytest.importorskip("distributed")
    import dask

    from arrayproc.app.batch import start_client
    before = dask.config.get("scheduler", None)
    out = {}
    for n in (1, 2):
        out[n] = start_client(workers=n, threads=1)
        out[n][0].wait_for_workers(n)
    yield {n: c for n, (c, _) in out.items()}
    # last opened, first closed: each client restores the dask scheduler it found, so
    # closing in opening order would leave the second's "dask.distributed" as the default
    for c, cluster in reversed(list(out.values())):
        c.close()
        cluster.close()
    dask.config.set(scheduler=before)  # older distributed releases leave their own default
