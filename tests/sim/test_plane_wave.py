"""Closed-form plane waves and the line-array pattern (thesis eqs. (2.10), (2.13))."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from arrayproc.io.geometry import line_array
from arrayproc.sim.pattern import line_array_pattern
from arrayproc.sim.plane_wave import (
    broadband_plane_waves,
    plane_wave_advances,
    tonal_plane_wave,
    towed_tonal_plane_waves,
)

C = 1500.0


@given(st.floats(0.0, 180.0), st.floats(10.0, 2000.0))
@settings(max_examples=30, deadline=None)
def test_tonal_is_the_reference_signal_advanced(cone, freq):
    """Element n is the origin's signal x_n cos θ0 / c earlier: x_n(t) = x_0(t + τ_n)."""
    fs, n = 8192.0, 256
    pos = line_array(8, 0.5)
    x = tonal_plane_wave(n, fs, pos, cone, freq, amp=1.7, phase=0.4)
    tau = pos[:, 0] * np.cos(np.deg2rad(cone)) / C
    t = np.arange(n) / fs
    want = 1.7 * np.cos(2 * np.pi * freq * (t[:, None] + tau[None, :]) + 0.4)
    # one cos of the same argument, different grouping of the sum: a few ulps of 2π f t
    assert np.max(np.abs(x - want)) < 1e-9


def test_advances_follow_the_cone_convention():
    pos = line_array(4, 1.0)
    assert np.allclose(plane_wave_advances(pos, 90.0), 0.0, atol=1e-18)
    fwd = plane_wave_advances(pos, 0.0)
    assert np.allclose(fwd, pos[:, 0] / C)   # forward end-fire: the element ahead hears first
    assert np.allclose(plane_wave_advances(pos, 180.0), -fwd)


def test_broadband_delay_is_exact_in_the_frequency_domain():
    """Each channel's spectrum is the source's times e^{j2πfτ_n}, to rounding of the FFT."""
    fs, n = 4096.0, 2048
    pos = line_array(5, 0.75)
    rng = np.random.default_rng(7)
    x = broadband_plane_waves(n, fs, pos, [63.0], [0.8], rng)
    s = np.fft.rfft(0.8 * np.random.default_rng(7).standard_normal(n))
    f = np.fft.rfftfreq(n, 1 / fs)
    X = np.fft.rfft(x, axis=0)
    want = s[:, None] * np.exp(2j * np.pi * f[:, None] * plane_wave_advances(pos, 63.0)[None])
    # the Nyquist bin of an irfft keeps only the real part: compare below it
    assert np.allclose(X[:-1], want[:-1], rtol=0, atol=1e-9 * np.abs(s).max())
    # broadside: every element holds the same samples
    y = broadband_plane_waves(n, fs, pos, [90.0], [1.0], np.random.default_rng(1))
    assert np.allclose(y, y[:, :1], atol=1e-12)


def test_sources_add():
    fs, n = 2048.0, 1024
    pos = line_array(3, 1.0)
    both = broadband_plane_waves(n, fs, pos, [40.0, 120.0], [1.0, 0.5],
                                 np.random.default_rng(3))
    r = np.random.default_rng(3)
    a = broadband_plane_waves(n, fs, pos, [40.0], [1.0], r)
    b = broadband_plane_waves(n, fs, pos, [120.0], [0.5], r)
    assert np.allclose(both, a + b, atol=1e-12)


def test_pattern_main_lobe_nulls_and_first_sidelobe():
    """|I_NH| = N_H at θ0, zeros at ψ = 2πk/N_H, first sidelobe −13.26 dB for large N_H."""
    n, dx, f = 64, 0.75, 1000.0
    theta0 = 90.0
    assert line_array_pattern(np.array([theta0]), theta0, f, n, dx)[0] == n
    # first null: cos θ = cos θ0 + c / (f N dx)
    u1 = np.cos(np.deg2rad(theta0)) + C / (f * n * dx)
    null = np.rad2deg(np.arccos(u1))
    assert abs(line_array_pattern(np.array([null]), theta0, f, n, dx)[0]) < 1e-9 * n
    th = np.linspace(60.0, 90.0, 200001)
    p = 20 * np.log10(np.abs(line_array_pattern(th, theta0, f, n, dx)) / n + 1e-300)
    side = p[th < null - 1e-3]
    # interior peaks of the sidelobe region: the highest is the first sidelobe
    assert side.max() == pytest.approx(-13.26, abs=0.05)


def test_pattern_is_the_sum_of_the_element_phasors():
    """Direct sum Σ_n e^{jψn}, n = 0..N−1, equals the closed form (relative 1e-12: rounding of
    the geometric series)."""
    n, dx, f = 17, 0.4, 1700.0
    th = np.linspace(0.0, 180.0, 721)
    psi = 2 * np.pi * f * dx / C * (np.cos(np.deg2rad(th)) - np.cos(np.deg2rad(50.0)))
    direct = np.exp(1j * psi[:, None] * np.arange(n)[None]).sum(1)
    got = line_array_pattern(th, 50.0, f, n, dx)
    assert np.allclose(got, direct, rtol=0, atol=1e-10 * n)


def test_towed_waves_reduce_to_the_static_tonal_and_shift_with_the_array():
    """U = 0, no lateral offset: the static tonal; moving at U, element n at time t sees what
    a static array element at x_n + U t sees (the wave is stationary)."""
    fs, n = 4096.0, 512
    pos = line_array(6, 0.5)
    t = np.arange(n) / fs
    got = towed_tonal_plane_waves(t, pos, 0.0, [(300.0, 55.0, 0.7)], phases=[0.3])
    want = tonal_plane_wave(n, fs, pos, 55.0, 300.0, amp=0.7, phase=0.3)
    assert np.allclose(got, want, rtol=0, atol=1e-12)
    U = 2.5
    mv = towed_tonal_plane_waves(t, pos, U, [(300.0, 55.0, 1.0)])
    k = 200
    moved = pos.copy()
    moved[:, 0] += U * t[k]
    ref = np.cos(2 * np.pi * 300.0 * (t[k] + moved[:, 0] * np.cos(np.deg2rad(55.0)) / C))
    assert np.allclose(mv[k], ref, rtol=0, atol=1e-9)
    # a lateral offset l acts as the starboard path difference l sin θ / c
    lat = np.full(n, 0.2)
    la = towed_tonal_plane_waves(t, pos, 0.0, [(300.0, 90.0, 1.0)], lateral=lat)
    assert np.allclose(la[:, 0], np.cos(2 * np.pi * 300.0 * (t + 0.2 / C)), atol=1e-12)
