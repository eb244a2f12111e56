"""CLEAN of azimuth × elevation scans (``bearings`` key ``clean``): the pattern model of eq.
(K1) against the beamformer's batched numpy reference, and a source below a stronger one's
sidelobes found where the peak picker takes the sidelobes for sources."""

from __future__ import annotations

import numpy as np
import pytest

from arrayproc.dsp.peaks2d import angle_between, pick_peaks_2d
from arrayproc.sim.scenario import tetrahedron
from arrayproc.stages.beamform.cbf_azel import azel_power_reference, grid_axis, world_directions
from arrayproc.stages.passive.azel_clean import AzelPattern, band_correlation, clean_peaks

C = 1480.0
AZ = grid_axis(0.0, 360.0, 2.0, True)
EL = grid_axis(-30.0, 90.0, 2.0, False)


def test_band_correlation_is_the_mean_cosine():
    u = np.linspace(-3e-3, 3e-3, 41)
    f = np.linspace(100.0, 2000.0, 20001)
    want = np.cos(2 * np.pi * f[None, :] * u[:, None]).mean(axis=1)
    assert np.allclose(band_correlation(u, 100.0, 2000.0), want, atol=2e-4)


def plane_wave_power(pos, az, el, heading, freqs):
    """The band power of a unit flat-spectrum plane wave on the grid (numpy reference)."""
    k = world_directions(np.array([az - heading]), np.array([el]))[0]
    tau = (pos - pos.mean(0)) @ k / C
    x = np.exp(2j * np.pi * freqs[:, None] * tau[None, :])[None]  # (1, F, N)
    dirs = world_directions(AZ - heading, EL)
    return azel_power_reference(x, freqs, pos, dirs, C)[0] / (pos.shape[0] ** 2 * freqs.size)


def test_pattern_matches_the_beamformer_reference():
    pos = tetrahedron(1.84)
    freqs = np.linspace(100.0, 2000.0, 400)
    pat = AzelPattern(pos, C, AZ, EL, 100.0, 2000.0)
    for az, el, h in ((300.0, 6.0, 30.0), (45.5, 40.3, 0.0)):
        b = pat.pattern(az, el, h)
        ref = plane_wave_power(pos, az, el, h, freqs)
        assert np.max(np.abs(b - ref)) < 0.01
        assert b.max() == pytest.approx(1.0, abs=0.01)


def test_weaker_source_below_the_sidelobes_is_found():
    """Two flat-spectrum sources 4 dB apart at 10° and 8° elevation, 150° apart, in noise 30 dB
    below the stronger: CLEAN gives two components within 2° of them and no third; the 2-D
    peak picker above its threshold gives rows that are neither."""
    pos = tetrahedron(1.84)
    freqs = np.linspace(100.0, 2000.0, 200)
    src = [(300.0, 10.0, 1.0), (90.0, 8.0, 10 ** -0.4)]
    p = 1e-3 + sum(a * plane_wave_power(pos, az, el, 30.0, freqs) for az, el, a in src)
    pat = AzelPattern(pos, C, AZ, EL, 100.0, 2000.0)
    comps, noise = clean_peaks(p, pat, 30.0, AZ, EL, True, 3.0, 10.0, 20.0, 4)
    assert len(comps) == 2
    for (az, el, a), c in zip(src, comps, strict=True):
        assert angle_between(az, el, c[0], c[1]) < 2.0
        assert c[2] == pytest.approx(a, rel=0.1)
    # the fitted noise holds the noise and the grid's mismatch, far below either source
    assert 5e-4 < noise < 5e-3
    lev = 10 * np.log10(p).reshape(EL.size, AZ.size)
    peaks = pick_peaks_2d(lev, AZ, EL, float(np.median(lev)) + 1.0, 20.0, 4, True)
    false = [q for q in peaks if min(angle_between(az, el, q[0], q[1]) for az, el, _ in src)
             > 10.0]
    assert false  # the peak picker's sidelobe rows, which CLEAN does not give
