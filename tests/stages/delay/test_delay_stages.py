"""The transients → tde → localise chain on a simulated compact-array recording, and the
transient detector alone."""

from __future__ import annotations

import numpy as np
import pytest

from arrayproc.app.api import build_chain, run_chain
from arrayproc.errors import ConfigError
from arrayproc.io.products import ProductsWriter, read_products
from arrayproc.io.recording import Recording, RecordingWriter
from arrayproc.stages.delay.detect import TransientDetector, detect_transients

FS = 32000.0
C = 1484.0
BODY = np.array([[-0.86, -0.86, -0.67], [-0.86, -0.86, 0.48], [0.86, -0.86, -0.67],
                 [0.0, 0.0, 0.0], [-0.86, 0.86, -0.67], [0.86, 0.86, 0.67]])


def _pulses(rng, n, events, band=(200.0, 4000.0), amp=30.0, elements=BODY):
    """Recording samples (n, 6): Hann-tapered white pulses (20 ms) from body-frame positions
    at the given emission times, exact delays, unit white noise."""
    f = np.fft.rfftfreq(n, 1 / FS)
    inb = (f >= band[0]) & (f <= band[1])
    x = np.zeros((n, 6))
    m = int(0.02 * FS)
    for t_emit, src in events:
        p = np.zeros(n)
        p[:m] = rng.standard_normal(m) * np.hanning(m) * amp
        P = np.fft.rfft(p) * inb
        r = np.linalg.norm(elements - src, axis=1)
        for ch in range(6):
            x[:, ch] += np.fft.irfft(P * np.exp(-2j * np.pi * f * (t_emit + r[ch] / C)), n) \
                / r[ch]
    return x + rng.standard_normal(x.shape)


CHAIN = """
[input]
block = 8000

[[stage]]
type = "transients"
channel = 3
band = [200.0, 4000.0]
threshold_db = 10.0
background = 1.0
max_duration = 0.3

[[stage]]
type = "tde"
reference = 3
band = [200.0, 4000.0]

[[stage]]
type = "localise"
min_corr = 0.5
"""


@pytest.fixture(scope="module")
def products(tmp_path_factory):
    d = tmp_path_factory.mktemp("tdoa")
    rng = np.random.default_rng(0)
    srcs = [np.array([2.0, 1.0, 0.5]), np.array([-3.0, 2.0, -1.0]), np.array([1.5, -2.5, 1.0])]
    times = [0.01, 1.2, 2.93]  # the first and last events touch the file's ends
    x = _pulses(rng, int(3.0 * FS), list(zip(times, srcs)))
    rec_path = d / "rec.h5"
    with RecordingWriter(rec_path, FS, 6, positions=BODY, sound_speed=C) as w:
        w.append(x.astype(np.float32))
    spec = build_chain(CHAIN)
    out = d / "prod.h5"
    with Recording(rec_path) as rec, ProductsWriter(out, source=str(rec_path),
                                                     chain=CHAIN) as pw:
        run_chain(rec, spec, pw)
        world = np.asarray(rec.pose(0.0).elements)
    # body → world map of the static pose (a rotation and a shift), for the truth
    A, *_ = np.linalg.lstsq(np.c_[BODY, np.ones(6)], world, rcond=None)
    truth = [np.r_[s, 1.0] @ A for s in srcs]
    return read_products(out), truth, times


def test_every_event_detected_and_localised(products):
    p, truth, times = products
    det = p["transients"]
    assert len(det["time_start"]) == 3
    for t, t0, t1 in zip(times, det["time_start"], det["time_end"]):
        assert t0 - 0.01 <= t + 0.002 <= t1 + 0.01
    assert np.all(det["channel"] == 3)
    pos = p["localise"]
    assert len(pos["x"]) == 3
    got = np.c_[pos["x"], pos["y"], pos["z"]]
    for g, tr, cov in zip(got, truth, pos["cov"]):
        err = g - tr
        assert np.linalg.norm(err) < 0.1
        assert err @ np.linalg.solve(cov, err) < 30.0  # within a generous χ²₃ tail
    assert np.all(pos["n_used"] == 5)


def test_delays_respect_the_geometry(products):
    p, _, _ = products
    d = p["tde"]
    lim = np.linalg.norm(BODY - BODY[3], axis=1) / C + 1e-4
    assert np.all(np.abs(d["tau"]) <= lim + 1e-12)
    assert np.all(d["tau"][:, 3] == 0) and np.all(d["corr"][:, 3] == 1)
    assert d["attrs"]["reference"] == 3
    assert d["tau"].shape == d["sigma"].shape == d["corr"].shape == (3, 6)


def test_snapshot_mode_on_time_blocks(tmp_path):
    rng = np.random.default_rng(1)
    x = _pulses(rng, int(1.0 * FS), [(0.3, np.array([2.0, 0.0, 0.0]))])
    with RecordingWriter(tmp_path / "r.h5", FS, 6, positions=BODY, sound_speed=C) as w:
        w.append(x.astype(np.float32))
    spec = build_chain('[[stage]]\ntype = "tde"\nreference = 3\nnfft = 8192\nhop = 4096\n'
                       'band = [200.0, 4000.0]\ninterp = "sinc"\n')
    with Recording(tmp_path / "r.h5") as rec, ProductsWriter(tmp_path / "p.h5") as pw:
        run_chain(rec, spec, pw)
    d = read_products(tmp_path / "p.h5")["tde"]
    assert d["tau"].shape == (6, 6)  # (32000 − 8192) // 4096 + 1 snapshots
    np.testing.assert_allclose(np.diff(d["time"]), 4096 / FS)


@pytest.mark.parametrize("text, key", [
    ('[[stage]]\ntype = "tde"\nmethod = "magic"\n', "method"),
    ('[[stage]]\ntype = "tde"\nweighting = "roth"\n', "weighting"),
    ('[[stage]]\ntype = "localise"\n', "localise"),
    ('[[stage]]\ntype = "transients"\n[[stage]]\ntype = "localise"\n', "tde"),
    ('[[stage]]\ntype = "localise"\nmin_pairs = 2\n', "min_pairs"),
])
def test_config_errors_name_the_key(text, key):
    with pytest.raises(ConfigError, match=key):
        build_chain(text)


def test_detector_streaming_equals_whole():
    rng = np.random.default_rng(2)
    fs = 8000.0
    x = rng.standard_normal(int(12 * fs))
    for t0 in (2.0, 6.5, 11.8):
        i = int(t0 * fs)
        x[i:i + 400] += 10 * np.sin(2 * np.pi * 700 * np.arange(400) / fs)
    whole = detect_transients(x, fs, (300.0, 1500.0), threshold_db=8.0, background=2.0)
    det = TransientDetector(fs, (300.0, 1500.0), threshold_db=8.0, background=2.0)
    parts = []
    for i in range(0, x.size, 3001):
        parts += det.push(x[i:i + 3001])
    parts += det.push(np.zeros(0), final=True)
    assert parts == whole
    assert [round(e.time_start, 1) for e in whole] == [2.0, 6.5, 11.8]
    for e in whole:
        assert e.freq_lo <= 700 <= e.freq_hi and e.snr_db > 15


def test_detector_ignores_stationary_noise():
    x = np.random.default_rng(3).standard_normal(80000)
    assert detect_transients(x, 8000.0, (300.0, 1500.0), threshold_db=10.0) == []


def test_unwrap_method_agrees_with_xcorr(products, tmp_path):
    """method = "unwrap" runs on event blocks; its delays follow the GCC's to tens of µs (it is
    the worse estimator: docs/validation/delays.md, fig. 3.16) and respect the lag limit."""
    p, _, _ = products
    rng = np.random.default_rng(0)
    srcs = [np.array([2.0, 1.0, 0.5]), np.array([-3.0, 2.0, -1.0]), np.array([1.5, -2.5, 1.0])]
    x = _pulses(rng, int(3.0 * FS), list(zip([0.01, 1.2, 2.93], srcs)))
    with RecordingWriter(tmp_path / "r.h5", FS, 6, positions=BODY, sound_speed=C) as w:
        w.append(x.astype(np.float32))
    text = CHAIN.replace('band = [200.0, 4000.0]\n\n[[stage]]\ntype = "localise"',
                         'band = [200.0, 4000.0]\nmethod = "unwrap"\n\n[[stage]]\n'
                         'type = "localise"')
    assert 'method = "unwrap"' in text
    with Recording(tmp_path / "r.h5") as rec, ProductsWriter(tmp_path / "p.h5") as pw:
        run_chain(rec, build_chain(text), pw)
    d = read_products(tmp_path / "p.h5")["tde"]
    diff = np.abs(d["tau"] - p["tde"]["tau"])
    assert np.median(diff) < 2e-5
    assert np.all(np.abs(d["tau"]) <= np.linalg.norm(BODY - BODY[3], axis=1) / C + 1e-4 + 1e-12)


def test_planar_array_falls_back_to_directions(tmp_path):
    """A horizontal planar array: no 3-D positions, a bearing per event instead."""
    plane = np.array([[0.8, 0.0, 0.0], [-0.8, 0.0, 0.0], [0.0, 0.8, 0.0], [0.0, -0.8, 0.0],
                      [0.0, 0.0, 0.0], [0.5, 0.5, 0.0]])
    rng = np.random.default_rng(4)
    src_body = np.array([40.0, 30.0, 5.0])  # far: a plane wave
    x = _pulses(rng, int(1.5 * FS), [(0.5, src_body)], amp=2000.0, elements=plane)
    with RecordingWriter(tmp_path / "r.h5", FS, 6, positions=plane, sound_speed=C) as w:
        w.append(x.astype(np.float32))
    text = CHAIN.replace("channel = 3", "channel = 4").replace("reference = 3", "reference = 4")
    with Recording(tmp_path / "r.h5") as rec, ProductsWriter(tmp_path / "p.h5") as pw:
        run_chain(rec, build_chain(text), pw)
        world = np.asarray(rec.pose(0.0).elements)
    A, *_ = np.linalg.lstsq(np.c_[plane, np.ones(6)], world, rcond=None)
    u = (np.r_[src_body, 1.0] @ A) - (np.r_[0, 0, 0, 1.0] @ A)
    want = np.degrees(np.arctan2(u[0], u[1])) % 360
    g = read_products(tmp_path / "p.h5")
    assert "localise" not in g or "x" not in g["localise"]
    dirs = g["localise_directions"]
    assert len(dirs["bearing_deg"]) == 1
    assert abs((dirs["bearing_deg"][0] - want + 180) % 360 - 180) < 1.0
