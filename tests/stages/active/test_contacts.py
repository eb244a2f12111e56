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
