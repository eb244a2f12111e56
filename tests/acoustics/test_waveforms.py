"""Waveforms (thesis ch. 4): m-sequences, BPSK/HFM/CW, Doppler scale, eq. (4.6), ambiguity."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from arrayproc.acoustics import waveforms as wf


@pytest.mark.parametrize("order", range(2, 13))
def test_mls_is_maximal_length(order):
    s = wf.mls(order)
    n = (1 << order) - 1
    assert s.size == n
    assert int(s.sum()) == (n + 1) // 2  # balanced: one more 1 than 0
    b = 2.0 * s - 1.0
    # two-valued periodic autocorrelation: N at lag 0, -1 elsewhere
    r = np.real(np.fft.ifft(np.abs(np.fft.fft(b)) ** 2))
    assert r[0] == pytest.approx(n)
    np.testing.assert_allclose(r[1:], -1.0, atol=1e-9)


def test_bits_to_order():
    assert wf.bits_to_order(2047) == 11
    with pytest.raises(ValueError):
        wf.bits_to_order(2000)


def test_bpsk_is_phase_flipped_carrier():
    w = wf.bpsk(1500.0, 1.0, 127)
    t = np.linspace(0.0, 1.0, 20001)[1:-1]
    bit = np.minimum((t * 127).astype(int), 126)
    want = (2.0 * w.sequence[bit] - 1.0) * np.sin(2 * np.pi * 1500.0 * t)  # thesis eq. (4.1)
    np.testing.assert_allclose(w(t), want, atol=1e-12)
    assert w(np.array([-0.1, 1.1])).tolist() == [0.0, 0.0]
    assert w.bandwidth == pytest.approx(127.0)  # eq. (4.2): B = N / T


def test_hfm_instantaneous_frequency_is_hyperbolic():
    w = wf.hfm(1200.0, 1800.0, 2.0)
    fs = 200000.0
    t = np.arange(0, 2.0, 1 / fs)
    k = (1 / 1200.0 - 1 / 1800.0) / 2.0
    phase = -(2 * np.pi / k) * np.log1p(-k * 1200.0 * t)
    f_num = np.gradient(phase, t) / (2 * np.pi)
    np.testing.assert_allclose(f_num[10:-10], w.instantaneous_frequency(t)[10:-10], rtol=1e-6)
    assert w.instantaneous_frequency(np.array([0.0, 2.0])) == pytest.approx([1200.0, 1800.0])
    np.testing.assert_allclose(1 / w.instantaneous_frequency(t), 1 / 1200.0 - k * t, rtol=1e-12)


@settings(max_examples=30, deadline=None)
@given(r=st.floats(-50, 50), c=st.floats(1400, 1600))
def test_doppler_scale_inverse(r, c):
    d = wf.doppler_scale(r, c)
    assert d == pytest.approx((c - r) / (c + r))  # thesis eq. (4.8)
    assert wf.range_rate_from_scale(d, c) == pytest.approx(r, abs=1e-9)


def test_time_distortion_eq_4_6():
    T, a = 4.0, 1e-3
    t = np.linspace(0, T, 100001)
    d = wf.time_distortion(t, a, T) - t
    assert abs(d[0]) < 1e-15 and abs(d[-1]) < 1e-15
    # max of sin x (1 − cos x) is 3√3/4 at x = 2π/3
    assert np.max(d) == pytest.approx(a * 3 * np.sqrt(3) / 4, rel=1e-6)


def test_wideband_ambiguity_finds_delay_and_scale():
    w = wf.bpsk(1000.0, 0.5, 127, taper=0.05)
    fs, delay, d = 4000.0, 0.3125, wf.doppler_scale(8.0)
    t = np.arange(int(1.5 * fs)) / fs
    x = w(d * (t - delay))
    scales = d + np.linspace(-1e-3, 1e-3, 41)
    chi = wf.wideband_ambiguity(x, w, fs, scales)
    i, k = np.unravel_index(np.argmax(chi), chi.shape)
    assert abs(scales[i] - d) < 1e-4
    assert abs(k / fs - delay) <= 1 / fs


def test_ambiguity_function_peak_and_doppler_resolution():
    """Peak 1 at (0, 1); 3 dB Doppler width of a BPSK pulse ≈ 0.886 c / (2 f_c T) in range rate
    (the CW-like Doppler resolution of thesis eq. (4.3), two-way)."""
    w = wf.bpsk(1500.0, 1.0, 255)
    fs, c = 8000.0, 1500.0
    lags, chi = wf.ambiguity_function(w, fs, [1.0], 0.01)
    assert chi.max() == pytest.approx(1.0, abs=1e-9)
    assert lags[np.argmax(chi[0])] == 0.0
    ds = 1 + np.linspace(-6e-4, 6e-4, 121)
    pk = wf.wideband_ambiguity(w.sample(fs), w, fs, ds).max(axis=1)
    pk /= pk.max()
    above = ds[pk >= 1 / np.sqrt(2)]
    width = (above.max() - above.min()) * c / 2
    want = 0.886 * c / (2 * 1500.0 * 1.0)
    print(f"BPSK 3 dB Doppler width {width:.3f} m/s vs 0.886 c/(2 fc T) = {want:.3f} m/s")
    assert abs(width - want) < 0.1 * want
