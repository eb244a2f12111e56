"""2-D peaks of azimuth × elevation beams: two sources give two rows at their directions."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from arrayproc.dsp.peaks2d import angle_between, curvature_sigma, pick_peaks_2d
from arrayproc.sim.scenario import tetrahedron
from arrayproc.stages.beamform.cbf_azel import CBFAzEl
from arrayproc.stages.passive.bearings_azel import azel_rows, grid_axes
from tests.stages.beamform.test_cbf_azel import FS, blocks_of, body_vector, tone_plane_wave


@pytest.mark.filterwarnings("ignore:stage .cbf_azel.. key .band. reaches")
def test_two_sources_two_rows_at_their_directions():
    pos = tetrahedron(3.0)
    nfft = 1024
    f1, f2 = 28 * FS / nfft, 30 * FS / nfft  # two tones on bins, 219 and 234 Hz (< c/2d)
    src = [(70.0, 15.0, f1, 1.0), (230.0, -30.0, f2, 1.0)]
    x = sum(tone_plane_wave(2 * nfft, pos, body_vector(a, e), f, amp)
            for a, e, f, amp in src)
    st = CBFAzEl(nfft=nfft, hop=nfft, window="none", band=[f1 - 5, f2 + 5],
                 azimuth=[0, 360, 2], elevation=[-90, 90, 2])
    b = next(iter(st.process(blocks_of(x, pos))))
    level = 10 * np.log10(b.data[0, 0])
    rows = {k: [] for k in ("time", "azimuth_deg", "elevation_deg", "sigma_deg",
                            "bearing_port_deg", "bearing_stbd_deg", "cone_deg", "level_db",
                            "snr_db", "freq_lo", "freq_hi", "spl_db")}
    stage = SimpleNamespace(threshold_db=2.0, min_separation=10.0, max_peaks=8)
    azel_rows(stage, level, b.beams, 0.0, 0.0, 0.0, 1.0, 0.0, rows)
    # every source has a row near it, and the strongest row is one of them. Not within the
    # 2° step: below c/2d a 4-element array's beams are ~60° wide, and the other source's
    # pattern, added in power, tilts each peak (measured 2.8° and 4.3° here); 6° allowed
    # (rows beyond the two sources may appear: sidelobes of -4 dB)
    found = [min(angle_between(a, e, ra, re_) for ra, re_ in
                 zip(rows["azimuth_deg"], rows["elevation_deg"])) for a, e, _, _ in src]
    assert max(found) <= 6.0
    assert min(angle_between(a, e, rows["azimuth_deg"][0], rows["elevation_deg"][0])
               for a, e, _, _ in src) <= 6.0
    assert rows["bearing_port_deg"] == rows["azimuth_deg"]
    assert all(s > 0 for s in rows["sigma_deg"])


def test_peak_on_the_wrap_and_a_pole_plateau():
    az = np.arange(0, 360, 5.0)
    el = np.arange(-90, 91, 5.0)
    a, e = np.meshgrid(az, el)
    # a peak at azimuth 0 (across the wrap) and elevation 10, and a flat pole row
    y = -((((a + 180) % 360) - 180) ** 2 + (e - 10) ** 2) / 50.0
    peaks = pick_peaks_2d(y, az, el, -1.0, 5.0, 8, wrap=True)
    assert len(peaks) == 1
    assert abs(((peaks[0][0] + 180) % 360) - 180) < 1e-9 and abs(peaks[0][1] - 10) < 1e-9
    assert grid_axes(np.stack([a.ravel(), e.ravel()], -1))[2]


def test_sigma_from_curvature():
    # curvature c dB/deg², SNR s dB: σ = 1/sqrt(2·10^(s/10)·c·ln10/10)
    c, s = 0.5, 20.0
    want = 1 / np.sqrt(2 * 100 * c * np.log(10) / 10)
    assert curvature_sigma(-c, s, 0.01) == pytest.approx(want)
    assert curvature_sigma(-c, 80.0, 2.0) == pytest.approx(2 / np.sqrt(12))
