"""Matched-filter bank against thesis ch. 4 closed forms: Doppler resolution (eq. (4.3), two-way),
range resolution (eq. (4.4)), sidelobe plateau (eq. (4.5)); the bank against a direct
time-domain correlation; Doppler scale (eq. (4.8))."""

from __future__ import annotations

import numpy as np
import pytest

from arrayproc.acoustics import waveforms as wf
from arrayproc.stages.active import bank as bk

FS = 5120.0
C = 1500.0


def half_power_width(x: np.ndarray, y: np.ndarray) -> float:
    """Full width at half power of the peak of y(x), crossings linearly interpolated."""
    y = np.asarray(y, float) / np.max(y)
    k = int(np.argmax(y))
    lo = k
    while lo > 0 and y[lo - 1] >= 0.5:
        lo -= 1
    hi = k
    while hi < y.size - 1 and y[hi + 1] >= 0.5:
        hi += 1
    xl = np.interp(0.5, [y[lo - 1], y[lo]], [x[lo - 1], x[lo]])
    xr = np.interp(0.5, [y[hi + 1], y[hi]], [x[hi + 1], x[hi]])
    return float(xr - xl)


def echo_plane(w: wf.Waveform, band: tuple[float, float], rates: np.ndarray,
               delay: float = 2.0, n_s: float = 8.0, rate: float = 0.0):
    """Bank output of one noiseless echo (range rate ``rate``) at ``delay`` s."""
    rep = w.sample(FS)
    n = int(n_s * FS)
    t = np.arange(n) / FS - delay
    d = float(bk.doppler_scale(rate, C))
    x = w(d * t)
    plan = bk.band_plan(FS, n, band)
    X = np.fft.rfft(x, plan.n_fft)[plan.k0:plan.k0 + plan.n_bins].astype(np.complex64)
    bank = bk.replica_spectra(rep, FS, plan.f0, plan.df, plan.n_bins, bk.doppler_scale(rates, C))
    out = np.empty((rates.size, plan.n_bins), np.float32)
    bk.correlate(X, bank, out)
    return plan, X, bank, out


@pytest.fixture(scope="module")
def bpsk():
    return wf.bpsk(1500.0, 4.0, 2047)


def test_doppler_scale_eq_4_8():
    assert bk.doppler_scale(0.0, C) == 1.0
    r = 7.5
    assert np.isclose(bk.doppler_scale(r, C), (C - r) / (C + r))
    assert bk.doppler_scale(5.0, C) < 1.0  # opening: echo stretched


def test_doppler_resolution_eq_4_3(bpsk):
    """3 dB width in range rate within 5 % of 0.886 c/(2 fc T) (two-way form of eq. 4.3)."""
    rates = np.linspace(-0.3, 0.3, 241)
    band = (1500 - bpsk.bandwidth, 1500 + bpsk.bandwidth)
    plan, _, _, out = echo_plane(bpsk, band, rates)
    d, r = np.unravel_index(np.argmax(out), out.shape)
    assert abs(r / plan.fs_bb - 2.0) * C / 2 < 1.0
    width = half_power_width(rates, out[:, r])
    ref = bk.doppler_resolution(1500.0, 4.0, C)
    assert abs(width / ref - 1) < 0.05, (width, ref)


def test_range_resolution_eq_4_4_hfm():
    """Eq. (4.4) is the flat-spectrum width: an HFM of bandwidth B processed over its band
    has its 3 dB range width within 5 % of 0.886 c/(2B)."""
    h = wf.hfm(1244.0, 1756.0, 4.0)
    plan, X, bank, out = echo_plane(h, (1244.0, 1756.0), np.zeros(1))
    z = np.fft.ifft(X * bank[0], plan.n_bins * 16)
    rng = np.arange(z.size) / (plan.fs_bb * 16) * C / 2
    width = half_power_width(rng, np.abs(z) ** 2)
    ref = bk.range_resolution(512.0, C)
    assert abs(width / ref - 1) < 0.05, (width, ref)


def test_range_resolution_bpsk_between_band_limits(bpsk):
    """The BPSK's range width depends on the processed band (triangle correlation, sinc^2
    spectrum): main lobe fc +- B gives a narrower peak than eq. (4.4), the 3 dB band fc +- B/2
    a wider one; eq. (4.4) lies between them (within 15 % of both)."""
    ref = bk.range_resolution(bpsk.bandwidth, C)
    widths = []
    for h in (1.0, 0.5):
        band = (1500 - h * bpsk.bandwidth, 1500 + h * bpsk.bandwidth)
        plan, X, bank, out = echo_plane(bpsk, band, np.zeros(1))
        z = np.fft.ifft(X * bank[0], plan.n_bins * 16)
        rng = np.arange(z.size) / (plan.fs_bb * 16) * C / 2
        widths.append(half_power_width(rng, np.abs(z) ** 2))
    assert widths[0] < ref < widths[1]
    assert all(abs(w / ref - 1) < 0.15 for w in widths), widths


def test_sidelobe_plateau_eq_4_5(bpsk):
    """Mean of |chi|^2 over the default bank (+-15 m/s at the 3 dB resolution) and lags within
    T/4 of the echo (main lobe out) within 1 dB of -10 log10 N. (On a grid of whole Doppler
    bins, 2 rdot fc T / c integer, the m-sequence's sidelobes are lower: not the plateau.)"""
    rates = bk.range_rate_grid(None, 1500.0, 4.0, C, False)
    band = (1500 - 1.05 * bpsk.bandwidth, 1500 + 1.05 * bpsk.bandwidth)
    plan, _, _, out = echo_plane(bpsk, band, rates)
    p = out / out.max()
    lag = np.arange(plan.n_bins) / plan.fs_bb - 2.0
    sel = (np.abs(lag) > 0.02) & (np.abs(lag) < 1.0)
    level = 10 * np.log10(p[:, sel].mean())
    assert abs(level - bk.sidelobe_level_db(2047)) < 1.0, level


def test_peak_at_true_range_rate(bpsk):
    """An echo at 5.3 m/s peaks in the channel nearest 5.3 m/s, at its delay."""
    rates = np.arange(-8.0, 8.001, 0.1)
    band = (1500 - bpsk.bandwidth, 1500 + bpsk.bandwidth)
    plan, _, _, out = echo_plane(bpsk, band, rates, rate=5.3)
    d, r = np.unravel_index(np.argmax(out), out.shape)
    assert abs(rates[d] - 5.3) <= 0.051
    assert abs(r / plan.fs_bb - 2.0) < 3 / plan.fs_bb


def test_replica_spectra_match_sampled_scaled_pulse():
    """The chirp-z spectra of p(d t) equal the DFT of the pulse sampled at the scaled times
    (a smooth, well band-limited pulse, so sampling aliases nothing)."""
    w = wf.hfm(800.0, 1200.0, 0.2, taper=0.2)
    fs = 8000.0
    plan = bk.band_plan(fs, 4000, (700.0, 1300.0))
    rates = np.array([-12.0, 0.0, 9.0])
    bank = bk.replica_spectra(w.sample(fs), fs, plan.f0, plan.df, plan.n_bins,
                              bk.doppler_scale(rates, C))
    for i, d in enumerate(bk.doppler_scale(rates, C)):
        rep = w(d * np.arange(plan.n_fft) / fs)
        ref = np.conj(np.fft.fft(rep)[plan.k0:plan.k0 + plan.n_bins])
        ref /= np.sqrt(np.sum(np.abs(ref) ** 2))
        assert np.max(np.abs(bank[i] - ref)) < 1e-3 * np.max(np.abs(ref)), i


def test_correlate_matches_numpy():
    """correlate() (numba square law) equals |numpy ifft(X conj P)|^2."""
    rng = np.random.default_rng(1)
    k = 600
    bank = (rng.standard_normal((4, k)) + 1j * rng.standard_normal((4, k))).astype(np.complex64)
    x = (rng.standard_normal(k) + 1j * rng.standard_normal(k)).astype(np.complex64)
    out = np.empty((4, 500), np.float32)
    bk.correlate(x, bank, out, r0=0)
    ref = np.abs(np.fft.ifft(bank * x[None], axis=1)[:, :500]) ** 2
    assert np.allclose(out, ref, rtol=1e-4, atol=1e-6 * ref.max())
