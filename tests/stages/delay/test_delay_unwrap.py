"""Phase-unwrapping LLS delays (thesis eqs. (3.30)-(3.36)) and app. B's residue unwrapping."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from arrayproc.stages.delay.unwrap import (
    UnwrapEstimator,
    _ssr_after_step,
    lls_delay,
    unwrap_residues,
)


def test_lls_exact_line():
    f = np.linspace(950, 1050, 101)
    tau = 1.234e-3
    ph = 0.3 - 2 * np.pi * f * tau
    t, phi0, ssr = lls_delay(ph, f)
    assert t == pytest.approx(tau, rel=1e-12)
    assert phi0 == pytest.approx(0.3, abs=1e-9)
    assert ssr < 1e-15


def test_lls_matches_polyfit():
    rng = np.random.default_rng(0)
    f = np.linspace(100, 300, 77)
    ph = rng.standard_normal(77) - 0.01 * f
    slope, icpt = np.polyfit(f, ph, 1)
    t, phi0, _ = lls_delay(ph, f)
    assert t == pytest.approx(-slope / (2 * np.pi), rel=1e-10)
    assert phi0 == pytest.approx(icpt, rel=1e-10)


@settings(max_examples=25, deadline=None)
@given(st.integers(1, 48), st.sampled_from([2 * np.pi, -2 * np.pi]), st.integers(0, 10**6))
def test_ssr_after_step_closed_form(j, a, seed):
    rng = np.random.default_rng(seed)
    f = np.linspace(100, 200, 50)
    ph = rng.standard_normal(50)
    plus, minus = _ssr_after_step(ph, f, 1, 50)
    got = (plus if a > 0 else minus)[j - 1]
    step = ph.copy()
    step[j:] += a
    assert got == pytest.approx(lls_delay(step, f)[2], rel=1e-9, abs=1e-9)


def test_residues_remove_planted_2pi_errors():
    rng = np.random.default_rng(1)
    f = np.linspace(950, 1050, 101)
    true = 0.2 - 2 * np.pi * f * 2.1e-3 + 0.05 * rng.standard_normal(101)
    bad = true.copy()
    bad[30:] += 2 * np.pi
    bad[70:] -= 4 * np.pi
    fixed, n = unwrap_residues(bad, f, threshold=0.2)
    assert n == 3
    d = fixed - true
    assert np.allclose(d, d[0], atol=1e-9)
    assert lls_delay(fixed, f)[0] == pytest.approx(lls_delay(true, f)[0], rel=1e-9)


def test_estimator_recovers_delay_of_periodic_signal():
    rng = np.random.default_rng(2)
    fs, n, band = 5120.0, 5120, (900.0, 1100.0)
    f = np.fft.rfftfreq(n, 1 / fs)
    inb = (f >= band[0]) & (f <= band[1])
    c = (rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size)) * inb
    taus = [0.0, 1.7e-3, -0.6e-3]
    x = np.stack([np.fft.irfft(c * np.exp(-2j * np.pi * f * t), n) for t in taus], 1)
    d = UnwrapEstimator(n, fs, 0, band)(x)
    np.testing.assert_allclose(d.tau[0], taus, atol=1e-9)
    assert np.all(d.corr[0] > 0.999)
