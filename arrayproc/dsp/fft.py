"""The one place FFTs are computed: pyfftw with cached plans, falling back to scipy.fft.

Hot loops use :class:`BufferedPlan` (fixed-shape reusable buffers), which runs ``ducc0.fft``
when it is installed (optional extra ``fast``; SIMD across the transforms of a batch, the
fastest here for every shape the stages plan), else ``scipy.fft``; FFTW on request.

Every back-end keeps single precision for float32/complex64 input. Outputs are fresh arrays the
caller owns. ``set_threads`` sets the FFTW thread count. The default is one thread: the
stages already run their FFTs beside numba and BLAS threads, and on this project's 2-core
machine a two-thread FFTW plan was measured 1.3-25x *slower* than a one-thread plan for the
shapes the stages use (e.g. a 256-point inverse FFT of 1021 rows: 0.33 ms with one thread,
8 ms with two; `docs/performance.md`).

pyfftw and scipy.fft are imported when first used, not with this module (together about
1.2 s of every command's start-up, docs/performance/startup.md); ducc0 (10 ms) is imported here.
"""

from __future__ import annotations

import importlib.util
from types import ModuleType

import numpy as np

try:
    import ducc0.fft as _ducc  # about 10 ms to import

    HAVE_DUCC = True
except ImportError:  # optional extra ``fast``
    HAVE_DUCC = False

#: pyfftw is installed; it is imported on first use (:func:`_pyfftw`): with dask installed,
#: ``import pyfftw`` imports ``dask.array`` too, about 0.9 s of start-up here
HAVE_PYFFTW = importlib.util.find_spec("pyfftw") is not None
_pyfftw_module: ModuleType | None = None


def _pyfftw() -> ModuleType | None:
    """The ``pyfftw`` module with its builders, imported once on first use; None without it."""
    global HAVE_PYFFTW, _pyfftw_module
    if _pyfftw_module is None and HAVE_PYFFTW:
        try:
            import pyfftw
            import pyfftw.builders  # noqa: F401  (the attribute used below)

            _pyfftw_module = pyfftw
        except ImportError:  # pragma: no cover - a broken install: fall back to scipy.fft
            HAVE_PYFFTW = False
    return _pyfftw_module


def _scipy_fft() -> ModuleType:
    """``scipy.fft``, imported on first use (about 0.3 s with scipy.special, which it loads)."""
    import scipy.fft

    return scipy.fft


def empty_aligned(shape: tuple[int, ...], dtype: np.dtype | type, align: int = 64) -> np.ndarray:
    """Uninitialised C-contiguous array whose data start on an ``align``-byte boundary (as
    ``pyfftw.empty_aligned``, which would import pyfftw: 64 bytes covers AVX-512 and a cache
    line, so that threads writing pieces of one array a multiple of 64 bytes long never share
    a line)."""
    dtype = np.dtype(dtype)
    nbytes = int(np.prod(shape, dtype=np.int64)) * dtype.itemsize
    raw = np.empty(nbytes + align, np.uint8)
    start = -raw.ctypes.data % align
    return raw[start:start + nbytes].view(dtype).reshape(shape)


_threads = 1
_plans: dict[tuple, object] = {}
_MAX_PLANS = 64


def set_threads(n: int) -> None:
    """Number of threads FFTW uses for new plans."""
    global _threads
    _threads = max(1, int(n))
    _plans.clear()


def _plan(kind: str, x: np.ndarray, n: int | None, axis: int):
    key = (kind, x.shape, x.dtype.str, n, axis % x.ndim, _threads)
    p = _plans.get(key)
    if p is None:
        if len(_plans) >= _MAX_PLANS:
            _plans.clear()
        build = getattr(_pyfftw().builders, kind)
        p = build(empty_aligned(x.shape, x.dtype), n=n, axis=axis, threads=_threads,
                  planner_effort="FFTW_ESTIMATE", auto_align_input=True, auto_contiguous=True,
                  avoid_copy=False)
        _plans[key] = p
    return p


def _run(kind: str, x: np.ndarray, n: int | None, axis: int) -> np.ndarray:
    x = np.asarray(x)
    if x.dtype not in (np.float32, np.float64, np.complex64, np.complex128):
        x = x.astype(np.float64)
    if _pyfftw() is None:
        return getattr(_scipy_fft(), kind)(x, n=n, axis=axis)
    if kind in ("fft", "ifft") and x.dtype.kind == "f":
        x = x.astype(np.complex64 if x.dtype == np.float32 else np.complex128)
    if kind == "irfft" and x.dtype.kind == "f":
        x = x.astype(np.complex64 if x.dtype == np.float32 else np.complex128)
    if kind == "rfft" and x.dtype.kind == "c":
        raise TypeError("rfft needs real input")
    out = _plan(kind, x, n, axis)(x)
    return out.copy()


def rfft(x: np.ndarray, n: int | None = None, axis: int = -1) -> np.ndarray:
    """Real-input FFT along ``axis`` (unnormalised, as numpy)."""
    return _run("rfft", x, n, axis)


def irfft(x: np.ndarray, n: int | None = None, axis: int = -1) -> np.ndarray:
    """Inverse of :func:`rfft` (normalised by 1/n, as numpy)."""
    return _run("irfft", x, n, axis)


def fft(x: np.ndarray, n: int | None = None, axis: int = -1) -> np.ndarray:
    """Complex FFT along ``axis`` (unnormalised)."""
    return _run("fft", x, n, axis)


def ifft(x: np.ndarray, n: int | None = None, axis: int = -1) -> np.ndarray:
    """Inverse complex FFT along ``axis`` (normalised by 1/n)."""
    return _run("ifft", x, n, axis)


def next_fast_len(n: int) -> int:
    """Smallest FFT-friendly length >= n (a product of 2, 3, 5, 7 and 11).

    ``ducc0.fft.good_size`` when ducc0 is installed (the same sizes as
    ``scipy.fft.next_fast_len``, checked in tests/dsp/test_fft.py, without importing scipy.fft),
    else scipy's.
    """
    if HAVE_DUCC:
        return int(_ducc.good_size(int(n), False))
    return _scipy_fft().next_fast_len(int(n))


class BufferedPlan:
    """A reusable transform over fixed-shape aligned buffers, for hot loops.

    Fill :attr:`input` (an aligned array of the planned shape and dtype) in place, then call
    the plan: it returns the output (with FFTW and ducc0 a buffer the plan owns and overwrites
    on the next call; with scipy a fresh array). Large FFTW transforms (>= 2**20 points) are
    planned with ``FFTW_MEASURE``, small ones with ``FFTW_ESTIMATE``.

    ``backend="auto"`` takes ``ducc0.fft`` when it is installed (optional extra ``fast``), else
    ``scipy.fft``; ``"fftw"``, ``"ducc0"`` or ``"scipy"`` forces one. The choice is fixed, not
    timed, so that the same input gives the same bytes in every run (on small shapes the
    back-ends nearly tie, and their roundings differ). ``inplace=True`` (complex transforms)
    lets the transform overwrite :attr:`input` (ducc0 writes its output there: half the
    memory traffic of a cache-sized batch). Measured on this project's
    machine, one thread (ms): the CBF's per-snapshot rfft (2048, 64) along axis 0, ducc0 0.16,
    scipy.fft 0.19, the pyfftw wheel's FFTW 0.54; the DFT filter's rfft (8448, 64) 0.72, 1.22,
    3.36 and its complex fft 1.34, 2.12, 5.99 (docs/performance.md). Results agree to float
    rounding whichever is used.
    """

    KINDS = ("rfft", "irfft", "fft", "ifft")

    def __init__(self, kind: str, shape: tuple[int, ...], dtype: np.dtype | type,
                 axis: int = -1, backend: str = "auto", inplace: bool = False) -> None:
        if kind not in self.KINDS:
            raise ValueError(f"unknown transform {kind!r}")
        self.kind, self.axis = kind, axis % len(shape)
        dtype = np.dtype(dtype)
        self._workers = _threads
        self._inplace = bool(inplace) and kind in ("fft", "ifft")
        self.input = empty_aligned(shape, dtype)
        self.input[...] = 0
        if backend == "auto":
            backend = "ducc0" if HAVE_DUCC else "scipy"
        if backend == "fftw" and _pyfftw() is not None:
            effort = "FFTW_MEASURE" if self.input.size >= 1 << 20 else "FFTW_ESTIMATE"
            self._run = getattr(_pyfftw_module.builders, kind)(
                self.input, axis=axis, threads=_threads, planner_effort=effort,
                overwrite_input=False, avoid_copy=True, auto_align_input=False,
                auto_contiguous=False)
        elif backend == "ducc0" and HAVE_DUCC:
            self._run = self._ducc_runner()
        elif backend in ("scipy", "fftw", "ducc0"):  # scipy, or the fallback for a missing one
            self._sfft = _scipy_fft()
            backend, self._run = "scipy", self._scipy
        else:
            raise ValueError(f"unknown FFT back-end {backend!r}")
        self.backend = backend

    def _ducc_runner(self):
        """ducc0 transform into an output buffer the plan owns (numpy's normalisation)."""
        x, ax = self.input, (self.axis,)
        n = x.shape[self.axis]
        oshape = list(x.shape)
        if self.kind == "rfft":
            oshape[self.axis] = n // 2 + 1
            out = np.empty(oshape, np.result_type(x.dtype, np.complex64))
            return lambda: _ducc.r2c(x, axes=ax, forward=True, out=out)
        if self.kind == "irfft":
            m = 2 * (n - 1)
            oshape[self.axis] = m
            out = np.empty(oshape, np.float32 if x.dtype == np.complex64 else np.float64)
            return lambda: _ducc.c2r(x, axes=ax, lastsize=m, forward=False, inorm=2, out=out)
        out = x if self._inplace else np.empty(oshape, np.result_type(x.dtype, np.complex64))
        if self.kind == "fft":
            return lambda: _ducc.c2c(x, axes=ax, forward=True, out=out)
        return lambda: _ducc.c2c(x, axes=ax, forward=False, inorm=2, out=out)

    def _scipy(self) -> np.ndarray:
        return getattr(self._sfft, self.kind)(self.input, axis=self.axis, workers=self._workers,
                                              overwrite_x=self._inplace)

    def __call__(self) -> np.ndarray:
        return self._run()


_buffered: dict[tuple, BufferedPlan] = {}


def buffered_plan(kind: str, shape: tuple[int, ...], dtype: np.dtype | type = np.float32,
                  axis: int = -1) -> BufferedPlan:
    """A cached :class:`BufferedPlan` for ``kind`` in ("rfft", "fft", "irfft", "ifft")."""
    key = (kind, tuple(shape), np.dtype(dtype).str, axis, _threads)
    p = _buffered.get(key)
    if p is None:
        if len(_buffered) >= _MAX_PLANS:
            _buffered.clear()
        p = BufferedPlan(kind, tuple(shape), dtype, axis)
        _buffered[key] = p
    return p
