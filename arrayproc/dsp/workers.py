"""The worker threads of the stages that split nogil numba and BLAS work over the cores.

One pool per size, shared by all stages: a chain runs its stages one after the other in the
calling thread, so a stage's workers are idle while another stage runs. Each worker asks
OpenBLAS for a single thread of its own (``kernels.blas_threads``): OpenBLAS's threading on
the small per-bin GEMMs was ~3x slower than one thread per worker here.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor

from arrayproc.dsp.blas_threads import set_local_threads

_pools: dict[int, ThreadPoolExecutor] = {}


def pool(n: int) -> ThreadPoolExecutor:
    """The shared pool of ``n`` worker threads (single-threaded BLAS in each)."""
    if n not in _pools:
        _pools[n] = ThreadPoolExecutor(n, thread_name_prefix="arrayproc",
                                       initializer=set_local_threads, initargs=(1,))
    return _pools[n]


def count(threads: int) -> int:
    """Worker threads for a stage's ``threads`` parameter (0: all cores)."""
    return threads if threads > 0 else (os.cpu_count() or 1)
