"""arrayproc.dsp.fft: every back-end of BufferedPlan against numpy's FFT, for every kind."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from arrayproc.dsp import fft

BACKENDS = ["scipy"] + (["fftw"] if fft.HAVE_PYFFTW else []) + (["ducc0"] if fft.HAVE_DUCC
                                                                  else [])


def _input(kind: str, shape: tuple[int, ...], dtype: type, rng: np.random.Generator):
    x = rng.standard_normal(shape)
    if np.dtype(dtype).kind == "c":
        x = x + 1j * rng.standard_normal(shape)
    return x.astype(dtype)


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("kind,dtype", [("rfft", np.float32), ("rfft", np.float64),
                                        ("fft", np.complex64), ("ifft", np.complex64),
                                        ("irfft", np.complex64), ("irfft", np.complex128)])
@settings(max_examples=10, deadline=None)
@given(n=st.integers(2, 300), m=st.integers(1, 9), axis=st.integers(0, 1),
       seed=st.integers(0, 2**31 - 1))
def test_buffered_plan_matches_numpy(backend, kind, dtype, n, m, axis, seed):
    """Output (values, shape, precision) equals numpy's transform along ``axis`` to the
    rounding of the input precision, whichever back-end runs it."""
    shape = (n, m) if axis == 0 else (m, n)
    p = fft.BufferedPlan(kind, shape, dtype, axis=axis, backend=backend)
    assert p.backend == backend
    x = _input(kind, shape, dtype, np.random.default_rng(seed))
    p.input[...] = x
    got = p()
    want = getattr(np.fft, kind)(x.astype(np.complex128 if x.dtype.kind == "c" else
                                          np.float64), axis=axis)
    assert got.shape == want.shape
    single = np.dtype(dtype) in (np.float32, np.complex64)
    if single:  # single precision stays single
        assert got.dtype == (np.float32 if kind == "irfft" else np.complex64)
    tol = (2e-5 if single else 1e-12) * max(1.0, np.abs(want).max())
    assert np.abs(got - want).max() <= tol


def test_auto_backend_is_fixed_and_reuses_its_buffers():
    """The automatic choice does not depend on timing (same bytes in every run): ducc0 when
    installed, else scipy.fft."""
    p = fft.BufferedPlan("rfft", (256, 4), np.float32, axis=0)
    assert p.backend == ("ducc0" if fft.HAVE_DUCC else "scipy")
    p.input[...] = 1.0
    a = p().copy()
    p.input[...] = 2.0
    b = p()
    np.testing.assert_allclose(b, 2 * a, rtol=1e-6)


def test_unknown_kind_or_backend_is_refused():
    with pytest.raises(ValueError):
        fft.BufferedPlan("dct", (8,), np.float32)
    with pytest.raises(ValueError):
        fft.BufferedPlan("rfft", (8,), np.float32, backend="mkl")


@pytest.mark.skipif(not fft.HAVE_DUCC, reason="ducc0 (extra 'fast') not installed")
@settings(max_examples=200, deadline=None)
@given(n=st.one_of(st.integers(1, 5000), st.integers(5000, 10**9)))
def test_next_fast_len_is_scipys(n):
    """ducc0's good_size (used so that scipy.fft is not imported for it) picks the same FFT
    size as scipy.fft.next_fast_len: the same chains give the same frames either way."""
    import scipy.fft

    assert fft.next_fast_len(n) == scipy.fft.next_fast_len(n)


@pytest.mark.parametrize("shape,dtype", [((7,), np.float32), ((3, 5), np.complex64),
                                         ((0, 4), np.float64), ((2, 3, 4), np.complex128)])
def test_empty_aligned_is_aligned_and_contiguous(shape, dtype):
    for _ in range(5):  # several allocations: not aligned by luck
        a = fft.empty_aligned(shape, dtype)
        assert a.shape == shape and a.dtype == dtype and a.flags.c_contiguous
        assert a.flags.writeable and (a.size == 0 or a.ctypes.data % 64 == 0)  # empty: no data
