"""Quazi's bounds (thesis eqs. (3.28), (3.29)) and the CRLB they are the asymptotes of."""

from __future__ import annotations

import numpy as np
import pytest

from arrayproc.stages.delay import bounds


def test_closed_forms():
    T, f1, f2 = 1.0, 0.0, 1000.0
    # eq. (3.29) at SNR 1, by hand: sqrt(3 / (4 π² 1e9))
    assert bounds.quazi_high(1.0, T, f1, f2) == pytest.approx(np.sqrt(3 / (4 * np.pi**2 * 1e9)))
    assert bounds.quazi_low(1.0, T, f1, f2) == pytest.approx(np.sqrt(3 / (8 * np.pi**2 * 1e9)))


def test_crlb_asymptotes():
    T, f1, f2 = 1.0, 950.0, 1050.0
    assert bounds.crlb(1e6, T, f1, f2) == pytest.approx(bounds.quazi_high(1e6, T, f1, f2),
                                                        rel=1e-6)
    assert bounds.crlb(1e-6, T, f1, f2) == pytest.approx(bounds.quazi_low(1e-6, T, f1, f2),
                                                         rel=1e-5)
    s = np.logspace(-3, 3, 50)
    b = bounds.crlb(s, T, f1, f2)
    assert np.all(b >= bounds.quazi_high(s, T, f1, f2))
    assert np.all(b >= bounds.quazi_low(s, T, f1, f2))
    assert np.all(np.diff(b) < 0)


def test_bad_band():
    with pytest.raises(ValueError):
        bounds.crlb(1.0, 1.0, 100.0, 50.0)
