"""Fractional-delay kernel: error against the exact analytic sinusoid, numba against numpy."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from arrayproc.dsp.fracdelay import (
    HALF_WIDTH,
    OVERSAMPLING,
    PASSBAND,
    TABLE_PHASES,
    default_table,
    interpolate,
    kernel_value,
)

BAND = PASSBAND / OVERSAMPLING  # in-band edge in cycles per source sample (0.225)


def numpy_reference(sig: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Σ_j s[m + j] h(μ_q − j) with the continuous kernel evaluated directly (no table) at the
    fractional delay μ = u − m rounded to the nearest of TABLE_PHASES phases."""
    m = np.floor(u).astype(int)
    mu = np.round((u - m) * TABLE_PHASES) / TABLE_PHASES
    j = np.arange(-HALF_WIDTH + 1, HALF_WIDTH + 1)
    return np.sum(sig[m[..., None] + j] * kernel_value(mu[..., None] - j), axis=-1)


def inband_error_db(n_freqs: int = 60, n_pos: int = 4000, seed: int = 0) -> float:
    """Peak error (dB re the amplitude) of reading unit sinusoids at random positions."""
    rng = np.random.default_rng(seed)
    m = np.arange(400)
    worst = 0.0
    for f in np.linspace(0.0, BAND, n_freqs):
        ph = rng.uniform(0, 2 * np.pi)
        sig = np.cos(2 * np.pi * f * m + ph)
        u = rng.uniform(HALF_WIDTH + 1, m.size - HALF_WIDTH - 2, (n_pos, 1))
        y = interpolate(sig, u, default_table())[:, 0]
        exact = np.cos(2 * np.pi * f * u[:, 0] + ph)
        worst = max(worst, float(np.max(np.abs(y - exact))))
    return 20 * np.log10(worst)


def test_error_below_minus_60_db_in_band():
    err = inband_error_db()
    print(f"fractional-delay peak in-band error: {err:.1f} dB")
    assert err < -60.0


def test_numba_matches_numpy_reference():
    rng = np.random.default_rng(1)
    sig = rng.standard_normal(500)
    u = rng.uniform(HALF_WIDTH + 1, 480, (300, 3))
    got = interpolate(sig, u, default_table())
    ref = numpy_reference(sig, u)
    assert np.max(np.abs(got - ref)) < 1e-12 * np.max(np.abs(sig))


def test_integer_positions_reproduce_samples():
    rng = np.random.default_rng(2)
    sig = rng.standard_normal(100)
    u = np.arange(10, 90, dtype=float)[:, None]
    np.testing.assert_allclose(interpolate(sig, u, default_table())[:, 0], sig[10:90],
                               atol=1e-12)


@settings(max_examples=25, deadline=None)
@given(a=st.floats(-10, 10), b=st.floats(-10, 10), seed=st.integers(0, 2**16))
def test_linear_in_the_signal(a, b, seed):
    rng = np.random.default_rng(seed)
    s1, s2 = rng.standard_normal((2, 200))
    u = rng.uniform(HALF_WIDTH + 1, 180, (50, 2))
    t = default_table()
    lhs = interpolate(a * s1 + b * s2, u, t)
    rhs = a * interpolate(s1, u, t) + b * interpolate(s2, u, t)
    np.testing.assert_allclose(lhs, rhs, atol=1e-9 * (1 + abs(a) + abs(b)))
