"""DFT filtering (thesis 3.2.1.1): response spec, seamless streaming vs scipy.signal."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import signal

from arrayproc.chain.memory import array_blocks, run_stage
from arrayproc.errors import ConfigError
from arrayproc.evaluate.scenarios.thesis_passive import dense_response
from arrayproc.stages.condition.dft_filter import DFTFilter, tukey_band


def run(stage: DFTFilter, x: np.ndarray, fs: float, sizes, s0: int = 0):
    return run_stage(stage, x, fs, None, sizes, s0)


@pytest.mark.parametrize("band,alpha,cx", [((100.0, 2000.0), 0.1, False),
                                           ((0.0, 800.0), 0.2, False),
                                           ((300.0, 700.0), 0.25, True)])
def test_response_ripple_and_rejection(band, alpha, cx):
    fs = 5120.0
    stage = DFTFilter(band=list(band), taper=alpha, complex=cx)
    stage._setup(fs)
    f, mag = dense_response(stage.taps, fs)
    af = f if cx else np.abs(f)
    lo, hi = band
    w = alpha * (hi - lo) / 2
    flat = (af >= (lo + w if lo > 0 else 0)) & (af <= hi - w) & (f >= 0 if cx else True)
    stop = (af < lo) | (af > hi) | ((f < 0) if cx else False)
    db = 20 * np.log10(np.maximum(mag, 1e-300))
    ripple = db[flat].max() - db[flat].min()
    rejection = -db[stop].max()
    assert ripple < 0.1, ripple
    assert rejection >= 60.0, rejection
    # the realised response follows the thesis's Tukey band shape
    ideal = tukey_band(af, lo, hi, alpha)
    if cx:
        ideal[f < 0] = 0
    assert np.max(np.abs(mag - ideal)) < 2e-3


@pytest.mark.parametrize("decimate,cx,band", [(1, False, [100.0, 2000.0]),
                                              (2, False, [50.0, 1200.0]),
                                              (4, True, [300.0, 700.0])])
def test_streaming_equals_scipy_convolution_on_the_whole_signal(rng, decimate, cx, band):
    fs = 5120.0
    x = rng.standard_normal((30000, 3))
    stage = DFTFilter(band=band, taper=0.1, decimate=decimate, complex=cx)
    y, out = run(stage, x, fs, sizes=(1000, 8192, 777, 5000))
    ref = signal.fftconvolve(x, stage.taps[:, None], mode="same", axes=0)[::decimate]
    if cx:
        p = np.arange(0, x.shape[0], decimate)
        ref = ref * np.exp(-2j * np.pi * stage.fc * p / fs)[:, None]
    assert y.shape == ref.shape
    assert np.max(np.abs(y - ref)) < 1e-5 * np.max(np.abs(ref))
    # blocks tile the output sample grid without gaps or overlaps
    s0 = [o.meta.sample0 for o in out]
    n = [o.data.shape[0] for o in out]
    assert s0[0] == 0 and all(a + b == c for a, b, c in zip(s0, n, s0[1:]))
    assert all(o.fs == fs / decimate for o in out)
    assert all(abs(o.t0 - o.meta.sample0 * decimate / fs) < 1e-12 for o in out)


@settings(max_examples=10, deadline=None)
@given(sizes=st.lists(st.integers(1, 6000), min_size=1, max_size=5),
       s0=st.integers(0, 50))
def test_output_does_not_depend_on_block_boundaries(sizes, s0):
    r = np.random.default_rng(7)
    x = r.standard_normal((12000, 2))
    fs = 2048.0
    ref, _ = run(DFTFilter(band=[40.0, 400.0], taper=0.2, decimate=2), x, fs, (12000,), s0)
    y, _ = run(DFTFilter(band=[40.0, 400.0], taper=0.2, decimate=2), x, fs, sizes, s0)
    assert y.shape == ref.shape
    assert np.max(np.abs(y - ref)) < 1e-5 * np.max(np.abs(ref))


def test_tones_in_passband_pass_and_out_of_band_tones_are_rejected():
    fs, n = 4096.0, 1 << 16
    t = np.arange(n) / fs
    band = [200.0, 1000.0]
    f_pass, f_stop = 600.25, 1500.5
    x = np.stack([np.cos(2 * np.pi * f_pass * t), np.cos(2 * np.pi * f_stop * t)], -1)
    stage = DFTFilter(band=band, taper=0.1, decimate=2)
    y, _ = run(stage, x, fs, sizes=(3000, 4096))
    mid = slice(4000, y.shape[0] - 4000)  # away from the stream's ends
    rms_in = np.sqrt(0.5)
    gain_pass = 20 * np.log10(np.sqrt(np.mean(y[mid, 0] ** 2)) / rms_in)
    gain_stop = 20 * np.log10(np.sqrt(np.mean(y[mid, 1] ** 2)) / rms_in)
    assert abs(gain_pass) < 0.1, gain_pass
    assert gain_stop < -60, gain_stop


def test_config_errors_name_the_key():
    with pytest.raises(ConfigError, match="'decimate'"):
        list(DFTFilter(band=[100.0, 900.0], decimate=4).process(
            array_blocks(np.zeros((4096, 1)), 2048.0, None, (4096,))))
    with pytest.raises(ConfigError, match="'taper'"):
        DFTFilter(band=[1.0, 2.0], taper=1.5)
    with pytest.raises(ConfigError, match="'band'"):
        DFTFilter(band=[10.0, 5.0])
    with pytest.raises(ConfigError, match="'band'"):
        list(DFTFilter(band=[100.0, 3000.0]).process(
            array_blocks(np.zeros((4096, 1)), 2048.0, None, (4096,))))


@pytest.mark.parametrize("decimate,cx,band", [(1, False, [100.0, 2000.0]),
                                              (2, False, [50.0, 1200.0]),
                                              (4, True, [300.0, 700.0])])
@pytest.mark.parametrize("cut", [1, 4321, 10002])
def test_stream_started_later_equals_the_whole_stream_bit_for_bit(rng, decimate, cx, band, cut):
    """Frames lie on the absolute sample grid: the stream read from sample ``cut`` on (a
    segment) gives, one warm-up in, the same output samples as the whole stream, bit for bit;
    before that, still the same convolution to rounding (zeros stand for the samples before
    ``cut``, so only outputs within half a filter of it differ by more)."""
    fs = 5120.0
    x = rng.standard_normal((60000, 3))
    # both set up as the chain runner does (warm-up asked first), so both use one frame size
    ref = DFTFilter(band=band, taper=0.1, decimate=decimate, complex=cx)
    ref.warmup_seconds(fs)
    whole, _ = run(ref, x, fs, (8192,))
    stage = DFTFilter(band=band, taper=0.1, decimate=decimate, complex=cx)
    warm = stage.warmup_seconds(fs)
    assert stage._m == ref._m
    part, out = run(stage, x[cut:], fs, (3000, 777), s0=cut)
    first = -(-cut // decimate)  # first output sample of the part, on the output grid
    assert out[0].meta.sample0 == first and part.shape[0] == whole.shape[0] - first
    keep = np.arange(first, whole.shape[0]) * decimate >= cut + warm * fs
    assert keep.sum() >= 2000
    assert np.array_equal(part[keep], whole[first:][keep])
    hr = stage._half_r
    far = np.arange(first, whole.shape[0]) * decimate >= cut + hr
    assert np.max(np.abs(part[far] - whole[first:][far])) < 1e-5 * np.max(np.abs(whole))
