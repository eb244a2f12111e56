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


CHAIN = """
[[stage]]
type = "cbf_azel"
nfft = 1024
hop = 1024
window = "hann"
band = [150.0, 400.0]
azimuth = [0.0, 360.0, 2.0]
elevation = [-90.0, 90.0, 2.0]

[[stage]]
type = "integrate"
snapshots = 4

[[stage]]
type = "bearings"
threshold_db = 3.0
min_separation = 20.0
"""


def test_chain_true_azimuth_from_the_nav_heading(tmp_path):
    """recording → cbf_azel → integrate → bearings on a tetrahedron headed 30°: broadband noise
    from true azimuth 100°, elevation 20° gives rows at that direction (within the 2° step),
    the products declare the azimuth columns."""
    from arrayproc.app.api import build_chain, run_chain
    from arrayproc.io.products import ProductsWriter, read_products
    from arrayproc.io.recording import Recording, RecordingWriter

    pos = tetrahedron(1.84)
    n = 8 * 1024
    rng = np.random.default_rng(5)
    s = rng.normal(0, 1, n + 64)
    k = body_vector(100.0, 20.0, heading=30.0)
    tau = pos @ k / 1500.0  # advances: x_n(t) = s(t + τ_n), by a phase ramp (exact delay)
    spec = np.fft.rfft(s)
    f = np.fft.rfftfreq(s.size, 1 / FS)
    x = np.stack([np.fft.irfft(spec * np.exp(2j * np.pi * f * t), s.size)[:n] for t in tau], 1)
    x += rng.normal(0, 0.05, x.shape)
    with RecordingWriter(tmp_path / "r.h5", FS, 4, positions=pos, sound_speed=1500.0) as w:
        w.append(x.astype(np.float32))
        w.set_nav(np.array([0.0, 10.0]), np.zeros((2, 2)), np.array([30.0, 30.0]))
    with Recording(tmp_path / "r.h5") as rec, ProductsWriter(tmp_path / "p.h5") as pw:
        run_chain(rec, build_chain(CHAIN), pw)
    g = read_products(tmp_path / "p.h5")["bearings"]
    t = np.asarray(g["time"])
    assert np.unique(t).size == 2
    for tt in np.unique(t):
        i = np.flatnonzero(t == tt)[0]  # the strongest row of the snapshot
        assert angle_between(100.0, 20.0, g["azimuth_deg"][i], g["elevation_deg"][i]) <= 2.0
        assert g["bearing_port_deg"][i] == g["azimuth_deg"][i]
