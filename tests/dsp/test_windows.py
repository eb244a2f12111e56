"""arrayproc.dsp.windows: the closed-form time tapers against scipy.signal.get_window."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import get_window

from arrayproc.dsp.windows import COSINE_SUMS, time_taper


@pytest.mark.parametrize("name", sorted(COSINE_SUMS))
@pytest.mark.parametrize("nfft", [2, 3, 8, 255, 2048, 4097])
def test_cosine_tapers_are_scipys_periodic_windows(name, nfft):
    """Same formula as scipy's (cosine sum on linspace(-pi, pi, nfft + 1), last point
    dropped); tolerance 4 ulp of the peak in case either side reorders the sum."""
    want = get_window(name, nfft, fftbins=True)
    want = want / want.mean()
    got = time_taper(name, nfft)
    assert got.shape == (nfft,)
    np.testing.assert_allclose(got, want, rtol=0, atol=4 * np.finfo(float).eps * want.max())


def test_coherent_gain_is_one_and_none_is_flat():
    for name in [*COSINE_SUMS, "none", "bartlett"]:  # bartlett: through scipy, imported then
        assert time_taper(name, 512).mean() == pytest.approx(1.0, rel=1e-12)
    assert np.array_equal(time_taper("none", 16), np.ones(16))


def test_kaiser_of_numpy_matches_scipy():
    """dft_filter takes numpy's Kaiser window (no scipy.signal import): the same formula with
    numpy's I0, within 4 ulp of scipy's (the two I0 implementations round differently)."""
    from scipy.signal.windows import kaiser

    for m, beta in [(101, 2.0), (513, 5.65), (2049, 10.0), (4097, 14.0)]:
        np.testing.assert_allclose(np.kaiser(m, beta), kaiser(m, beta), rtol=4e-16 * 4,
                                   atol=4 * np.finfo(float).eps)
