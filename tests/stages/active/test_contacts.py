"""Contact geometry: bistatic range inverts the path, absolute Doppler of a still scatterer is
zero (eq. (4.9), opening-positive convention), bearings, merging."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from arrayproc.stages.active import contacts as ct


@given(r=st.floats(300.0, 30000.0), cone=st.floats(0.0, 180.0),
       px=st.floats(-100.0, 100.0), pz=st.floats(0.0, 50.0), u=st.floats(0.0, 8.0))
def test_bistatic_range_inverts_path(r, cone, px, pz, u):
    proj = np.array([px, 0.0, pz])
    path = ct.bistatic_path(r, cone, proj, u)
    assert np.isclose(ct.bistatic_range(path, cone, proj, u), r, rtol=1e-9, atol=1e-6)


def test_bistatic_range_moving_platform():
    """Platform at U along +x, projector at the array (p = 0), still scatterer at (x, y): the
    pulse leaves from -U tau relative to the array at reception; the range is recovered."""
    u, c = 4.0, 1500.0
    s = np.array([3000.0, 8000.0])
    r2 = np.linalg.norm(s)
    tau = r2 / c
    for _ in range(50):  # transmit point -u tau, tau = (|s - tx| + r2) / c
        tau = (np.linalg.norm(s - np.array([-u * tau, 0.0])) + r2) / c
    cone = np.rad2deg(np.arctan2(s[1], s[0]))
    assert np.isclose(ct.bistatic_range(c * tau, cone, np.zeros(3), u, c), r2, atol=1e-6)


def test_bistatic_path_geometry():
    """Projector 60 m ahead, scatterer 1000 m dead ahead: path 1000 + 940 m."""
    assert np.isclose(ct.bistatic_path(1000.0, 0.0, np.array([60.0, 0.0, 0.0])), 1940.0)


def test_absolute_doppler_still_scatterer():
    """A platform at U towards a still scatterer at cone theta measures rdot = -U cos(theta)
    (closing ahead), and the absolute Doppler is 0."""
    u = 3.0
    cone = np.array([0.0, 45.0, 90.0, 135.0, 180.0])
    rdot = -u * np.cos(np.deg2rad(cone))
    assert np.allclose(ct.absolute_doppler(rdot, cone, u), 0.0)
    assert np.allclose(ct.absolute_doppler(rdot + 2.0, cone, u), 2.0)


def test_bearings_and_merge():
    port, stbd = ct.bearings(180.0, np.array([30.0, 90.0]))
    assert np.allclose(port, [150.0, 90.0]) and np.allclose(stbd, [210.0, 270.0])
    keep = ct.merge(np.array([1000.0, 1001.0, 1000.5, 3000.0]), np.array([60.0, 62.0, 120.0,
                                                                           60.0]),
                    np.array([20.0, 30.0, 10.0, 15.0]), 5.0, 10.0)
    assert keep.tolist() == [1, 3, 2]


def test_merge_keeps_a_quiet_beam_echo():
    """The case of the direct blast (docs/validation/active.md, ping 23): a false alarm on a
    loud beam (peak 27.4 dB, SNR 12.8 dB, +3.73 m/s) within the path gate of the submarine's
    echo on a quiet beam (peak -1.9 dB, SNR 21.8 dB, -4.70 m/s). On the gates alone the echo
    is dropped; with range rate and SNR it stays. Its sidelobe image (same range rate, lower
    peak) is folded although its SNR is higher than the false alarm's, a weaker false alarm
    at another range rate is folded by the echo, one at another range rate with a higher SNR
    than the loud beam's is not."""
    path = np.array([4490.0, 4497.0, 4491.0, 4495.0, 4494.0])
    cone = np.array([94.0, 67.0, 70.0, 40.0, 110.0])
    peak = 10 ** (np.array([27.4, -1.9, -8.0, -10.0, -12.0]) / 10)
    snr = 10 ** (np.array([12.8, 21.8, 15.8, 12.4, 13.5]) / 10)
    rate = np.array([3.73, -4.70, -4.69, 9.0, -12.0])
    assert ct.merge(path, cone, peak, 11.7, 180.0).tolist() == [0]
    assert ct.merge(path, cone, peak, 11.7, 180.0, rate, 0.44, snr).tolist() == [0, 1]
    snr[4] = 10 ** 2.3  # above the echo's SNR: a different, stronger-SNR echo
    assert ct.merge(path, cone, peak, 11.7, 180.0, rate, 0.44, snr).tolist() == [0, 1, 4]


def test_merge_on_equal_noise_is_suppression_on_the_peak():
    rng = np.random.default_rng(7)
    for _ in range(50):
        n = int(rng.integers(1, 40))
        path = rng.uniform(0.0, 100.0, n)
        cone = rng.uniform(0.0, 180.0, n)
        peak = rng.exponential(1.0, n)
        rate = rng.uniform(-15.0, 15.0, n)
        a = ct.merge(path, cone, peak, 8.0, 20.0)
        np.testing.assert_array_equal(a, ct.merge(path, cone, peak, 8.0, 20.0, rate, 0.44,
                                                  peak / 0.37))
