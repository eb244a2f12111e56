"""A tone's offset between bins (``arrayproc.dsp.tone_offset``) against the taper's transform
summed directly and against noiseless tones of known frequency."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from arrayproc.dsp.tone_offset import taper_transform, tone_offset, vertex_curve
from arrayproc.dsp.windows import COSINE_SUMS, periodic_cosine_sum, time_taper

TAPERS = ("none", *COSINE_SUMS)


@pytest.mark.parametrize("window", TAPERS)
def test_closed_form_transform_equals_the_direct_sum(window):
    n = 300
    w = np.ones(n) if window == "none" else periodic_cosine_sum(COSINE_SUMS[window], n)
    nu = np.linspace(-4.0, 4.0, 161)  # integer offsets included (0/0 in the closed form)
    direct = np.exp(-2j * np.pi * np.outer(nu, np.arange(n)) / n) @ w
    got = taper_transform(window, n, nu)
    assert np.max(np.abs(got - direct)) <= 1e-12 * np.max(np.abs(direct))


def test_other_scipy_tapers_are_summed_directly():
    delta, curve = vertex_curve("flattop", 128)
    assert np.all(np.diff(curve) > 0) and curve[0] < 0 < curve[-1]


# a noiseless tone at bin 300 + δ of 2048: the error left is the negative-frequency image's
# leakage, larger for Hamming (far sidelobes near -43 dB fall off slowly: ~1e-4 bin) and for
# no taper (sidelobes falling as 1/ν: ~1.4e-3 bin, where the bare parabola is 0.17 bin off)
TOLERANCE_BINS = {"hann": 1e-6, "blackman": 1e-6, "blackmanharris": 1e-6, "hamming": 3e-4,
                  "none": 3e-3}


@pytest.mark.parametrize("window", sorted(TOLERANCE_BINS))
def test_noiseless_tone_exact_where_the_parabola_is_biased(window):
    n, k = 2048, 300
    t = np.arange(n)
    err, bare = [], []
    for d in np.linspace(-0.5, 0.5, 21):
        x = time_taper(window, n) * np.cos(2 * np.pi * (k + d) * t / n + 0.7)
        levels = 10 * np.log10(np.abs(np.fft.rfft(x)) ** 2)
        c = k - 2 + int(np.argmax(levels[k - 2:k + 3]))
        y0, y1, y2 = levels[c - 1:c + 2]
        bare.append(c + 0.5 * (y0 - y2) / (y0 - 2 * y1 + y2) - (k + d))
        err.append(c + tone_offset(levels[c - 1:c + 2], window, n) - (k + d))
    assert np.max(np.abs(err)) < TOLERANCE_BINS[window]
    assert np.max(np.abs(bare)) > 10 * np.max(np.abs(err))  # 0.003-0.016 bin


@settings(max_examples=60, deadline=None)
@given(st.floats(-0.49, 0.49), st.sampled_from(("hann", "blackman", "hamming")),
       st.sampled_from((64, 512, 4096)))
def test_odd_and_increasing(d, window, n):
    """Mirrored levels give the opposite offset; a tone further right gives a larger one."""
    nu = np.array([-1 - d, -d, 1 - d, -1 - d - 0.01, -d - 0.01, 1 - d - 0.01])
    y = 10 * np.log10(np.abs(taper_transform(window, n, nu)) ** 2)
    a, b = tone_offset(y[:3], window, n), tone_offset(y[3:], window, n)
    assert tone_offset(y[2::-1], window, n) == pytest.approx(-a, abs=1e-12)
    assert b > a or d + 0.01 > 0.5
    assert a == pytest.approx(d, abs=1e-6)


def test_not_a_maximum_gives_the_bin():
    assert tone_offset([0.0, -1.0, 0.0], "hann", 256) == 0.0
