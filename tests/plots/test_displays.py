"""The analyst's displays: bearings, BTR with detections, bearing-frequency, array geometry,
raw-channel spectrogram, and the time/frequency limits of every plot. Each is checked for
labelled axes with units, sonar orientation (time down), its numbers against closed forms,
and the limits it was given."""

from __future__ import annotations

import re

import matplotlib.figure
import numpy as np
import pytest
from matplotlib.figure import Figure

from arrayproc.app.cli import main
from arrayproc.io.products import read_products
from tests.conftest import write_recording


def _bearings(n=40, seed=5):
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 39.0, n)
    cone = 60.0 + 0.5 * t
    return {"time": t, "cone_deg": cone, "bearing_port_deg": (90.0 - cone) % 360.0,
            "bearing_stbd_deg": 90.0 + cone, "snr_db": rng.uniform(5.0, 25.0, n),
            "attrs": {}}


def _lofar(n=4, beams=7, bins=50):
    p = np.zeros((n, beams, bins))
    p[0, 3, 20], p[1, 3, 20] = 10.0, 0.0  # mean in power: 10·log10((10 + 1) / 2)
    return {"time": np.arange(n, dtype=float), "cone_deg": np.linspace(0.0, 180.0, beams),
            "freq": np.linspace(100.0, 149.0, bins), "power_db": p, "attrs": {}}


def _captured(monkeypatch) -> list:
    """Figures saved by the plot command (savefig is wrapped to keep them)."""
    kept: list = []
    save = matplotlib.figure.Figure.savefig

    def keep(self, *a, **k):
        kept.append(self)
        return save(self, *a, **k)
    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", keep)
    return kept


def test_bearings_port_and_starboard_against_time_coloured_by_snr():
    from arrayproc.plots.bearings import draw_bearings
    g = _bearings()
    fig = Figure()
    axes = fig.subplots(1, 2, sharey=True)
    assert draw_bearings(g, {}, axes, truth=False) is fig
    for ax, col in zip(axes, ("bearing_port_deg", "bearing_stbd_deg")):
        sc = ax.collections[0]
        np.testing.assert_array_equal(sc.get_offsets()[:, 0], g[col] % 360.0)
        np.testing.assert_array_equal(sc.get_array(), g["snr_db"])  # colour = SNR
        assert ax.get_xlabel() == "true bearing (deg, clockwise from north)"
        assert ax.get_xlim() == (0.0, 360.0)
    assert axes[0].get_ylabel() == "time (s since recording start)"
    lo, hi = axes[0].get_ylim()
    assert lo > hi  # time runs down
    assert "SNR" in fig.axes[-1].get_ylabel() and "(dB)" in fig.axes[-1].get_ylabel()


def test_bearings_truth_is_drawn_on_the_side_the_source_is(towed_run):
    from arrayproc.plots.bearings import draw_bearings
    prod = read_products(towed_run)
    fig = draw_bearings(prod["bearings"], prod.root, Figure().subplots(1, 2))
    port, stbd = fig.axes[:2]
    names = {ax: {ln.get_label() for ln in ax.lines} for ax in (port, stbd)}
    assert "truth: merchant" in names[port] and "truth: submarine" in names[stbd]
    assert "truth: merchant" not in names[stbd]


def test_btr_draws_the_bearing_detections_within_its_span():
    from arrayproc.plots.btr import draw_btr
    g = {"time": np.arange(10.0), "cone_deg": np.linspace(0.0, 180.0, 19),
         "power_db": np.zeros((10, 19)), "attrs": {}}
    det = _bearings()
    ax = Figure().subplots()
    draw_btr(g, {}, ax, truth=False, detections=det)
    inside = det["time"] <= 9.0
    off = ax.collections[0].get_offsets()
    np.testing.assert_array_equal(off[:, 0], det["cone_deg"][inside])
    np.testing.assert_array_equal(off[:, 1], det["time"][inside])
    assert ax.get_legend().get_texts()[0].get_text() == f"bearing detections ({inside.sum()})"


def test_bearing_frequency_averages_power_with_frequency_up():
    from arrayproc.plots.bearing_frequency import draw_bearing_frequency
    g = _lofar()
    ax = Figure().subplots()
    draw_bearing_frequency(g, {"units": "Pa"}, ax, truth=False)
    img = ax.images[0].get_array()
    assert img.shape == (50, 7)  # frequency rows, beams across
    assert img[20, 3] == pytest.approx(10 * np.log10((10 ** 1.0 + 3) / 4), rel=1e-12)
    assert ax.get_xlabel().startswith("cone angle (deg") and ax.get_ylabel() == "frequency (Hz)"
    lo, hi = ax.get_ylim()
    assert lo < hi and lo < 100.0 < 149.0 < hi  # frequency up
    assert "µPa²" in ax.figure.axes[-1].get_ylabel()


def test_geometry_of_a_line_array_states_aperture_and_spacing(tmp_path, monkeypatch):
    pos = np.zeros((8, 3))
    pos[:, 0] = -0.5 * np.arange(8)
    rec = write_recording(tmp_path / "r.h5", np.zeros((100, 8), np.float32), positions=pos)
    kept = _captured(monkeypatch)
    assert main(["plot", str(rec), "--kind", "geometry", "-o", str(tmp_path / "g.png"),
                 "-q"]) == 0
    plan, side = kept[0].axes[:2]
    assert "aperture 3.50 m, median spacing 0.500 m" in kept[0].texts[0].get_text()
    np.testing.assert_allclose(plan.lines[0].get_xdata(), pos[:, 0])
    assert plan.get_xlabel() == "x forward (m)" and plan.get_ylabel() == "y starboard (m)"
    assert side.get_ylabel() == "z down (m)" and side.get_ylim()[0] > side.get_ylim()[1]


def test_spectrogram_level_and_limits_of_a_tone(tmp_path, monkeypatch):
    fs, f0, a = 2000.0, 250.0, 0.5  # a 0.5 Pa tone: mean square a²/2
    t = np.arange(int(20 * fs)) / fs
    x = np.zeros((t.size, 2), np.float32)
    x[:, 1] = a * np.sin(2 * np.pi * f0 * t)
    rec = write_recording(tmp_path / "r.h5", x, fs=fs)
    kept = _captured(monkeypatch)
    out = tmp_path / "s.png"
    assert main(["plot", str(rec), "--kind", "spectrogram", "--channel", "1", "--t0", "5",
                 "--t1", "15", "--fmin", "100", "--fmax", "400", "-o", str(out), "-q"]) == 0
    ax = kept[0].axes[0]
    assert ax.get_xlim() == (100.0, 400.0) and ax.get_ylim() == (15.0, 5.0)  # time down
    assert ax.get_xlabel() == "frequency (Hz)"
    assert ax.get_ylabel() == "time (s since recording start)"
    assert "dB re 1 µPa²/Hz" in kept[0].axes[1].get_ylabel()
    img = np.asarray(ax.images[0].get_array())  # (time, freq) over 100-400 Hz
    x0, x1 = ax.images[0].get_extent()[:2]
    df = (x1 - x0) / img.shape[1]
    psd = 10 ** (img / 10) * 1e-12  # back to Pa²/Hz
    ms = psd.sum(axis=1) * df  # Parseval: the tone's mean square, a²/2, in every frame
    np.testing.assert_allclose(10 * np.log10(ms / (a * a / 2)), 0.0, atol=0.1)
    peak = x0 + (np.argmax(img.mean(axis=0)) + 0.5) * df
    assert abs(peak - f0) <= df


@pytest.mark.parametrize("kind", ["btr", "lofar", "bearings", "bearing_frequency"])
def test_time_and_frequency_limits_are_honoured(towed_run, tmp_path, monkeypatch, kind):
    kept = _captured(monkeypatch)
    args = ["plot", str(towed_run), "--kind", kind, "--t0", "4", "--t1", "9", "-o",
            str(tmp_path / f"{kind}.png"), "-q"]
    if kind in ("lofar", "bearing_frequency"):
        args += ["--fmin", "100", "--fmax", "300"]
    assert main(args) == 0
    ax = kept[0].axes[0]
    if kind != "bearing_frequency":
        assert ax.get_ylim() == (9.0, 4.0)  # the window, time running down
    if kind == "lofar":
        assert ax.get_xlim() == (100.0, 300.0)
    if kind == "bearing_frequency":
        assert ax.get_ylim() == (100.0, 300.0)
        first, last = map(float, re.search(r"over ([\d.]+)-([\d.]+) s", ax.get_title()).groups())
        assert 4.0 <= first <= last <= 9.0  # the mean is over the rows in the window only


def test_bad_limits_are_refused_in_one_line(towed_run, tmp_path, capsys):
    for extra, msg in ((["--t0", "9", "--t1", "4"], "--t0 must be below --t1"),
                       (["--t0", "500"], "no rows between --t0 500"),
                       (["--fmin", "-1"], "--fmin must be >= 0 Hz")):
        out = tmp_path / "x.png"
        assert main(["plot", str(towed_run), "--kind", "lofar", *extra, "-o", str(out)]) == 2
        err = capsys.readouterr().err
        assert msg in err and err.count("\n") == 1 and not out.exists()
