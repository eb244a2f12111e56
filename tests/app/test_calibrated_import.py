"""Calibrated imports: FLAC and AIFF through libsndfile, a sensitivity, gain and full-scale
voltage (or a frequency-response sheet) turning full scale into pascals, through the CLI."""

from __future__ import annotations

import numpy as np
import pytest

from arrayproc.app.cli import main
from arrayproc.io.calibration import ResponseFilter, pascals_per_full_scale
from arrayproc.io.products import read_products
from arrayproc.io.recording import Recording

sf = pytest.importorskip("soundfile")

FS = 8000
SENS, GAIN, VFS = -170.0, 20.0, 2.0  # dB re 1 V/µPa, dB, V


def _recorded_tone(path, fmt, subtype, p_rms=1.0, f0=1000.0, seconds=4.0, n_ch=2):
    """A p_rms-Pa tone as a recorder with the stated chain stores it, in full scale."""
    t = np.arange(int(seconds * FS)) / FS
    p_upa = p_rms * np.sqrt(2) * 1e6 * np.sin(2 * np.pi * f0 * t)  # µPa
    volts = p_upa * 10 ** ((SENS + GAIN) / 20)
    x = np.repeat((volts / VFS)[:, None], n_ch, axis=1)
    sf.write(str(path), x, FS, format=fmt, subtype=subtype)
    return path


def _power_chain(tmp_path):
    chain = tmp_path / "power.toml"
    chain.write_text('[input]\nblock = 8000\n\n[[stage]]\ntype = "power"\n'
                     'band = [900.0, 1100.0]\n', encoding="utf-8")
    return chain


@pytest.mark.parametrize("ext,fmt,subtype", [("flac", "FLAC", "PCM_24"),
                                             ("aiff", "AIFF", "PCM_24")])
def test_a_1_pa_tone_reads_120_db_re_1_upa_after_import(tmp_path, ext, fmt, subtype, capsys):
    src = _recorded_tone(tmp_path / f"tone.{ext}", fmt, subtype)
    rec, prod = tmp_path / "rec.h5", tmp_path / "p.h5"
    assert main(["import", str(src), "-o", str(rec), "--line", "2", "0.5",
                 "--sensitivity", str(SENS), "--gain", str(GAIN),
                 "--full-scale-volts", str(VFS), "-q"]) == 0
    with Recording(rec) as r:
        assert r.units == "Pa"
        assert "sensitivity -170 dB re 1 V/µPa" in r._td.attrs["calibration"]
    assert main(["process", str(rec), "-c", str(_power_chain(tmp_path)), "-o", str(prod),
                 "-q", "--no-progress"]) == 0
    g = read_products(prod)
    level = g["power"]["power_db"]
    assert np.all(np.abs(level - 120.0) < 0.1), level
    assert g.root["units"] == "Pa"
    assert capsys.readouterr().err == ""


def test_without_calibration_the_levels_are_in_full_scale(tmp_path):
    src = _recorded_tone(tmp_path / "tone.flac", "FLAC", "PCM_24", n_ch=1)
    rec = tmp_path / "rec.h5"
    assert main(["import", str(src), "-o", str(rec), "-q"]) == 0
    with Recording(rec) as r:
        assert r.units == "FS"
        rms = float(np.sqrt(np.mean(r.read(0, FS, np.float64) ** 2)))
    assert rms == pytest.approx(1e6 * 10 ** ((SENS + GAIN) / 20) / VFS, rel=1e-4)


@pytest.mark.parametrize("args,needle", [
    (["--gain", "20"], "needs --sensitivity"),
    (["--sensitivity", "-170"], "needs --full-scale-volts"),
    (["--sensitivity", "-170", "--full-scale-volts", "1", "--scale", "3"], "give one"),
    (["--sensitivity", "nan", "--full-scale-volts", "1"], "--sensitivity must be"),
    (["--sensitivity", "-170", "--full-scale-volts", "0"], "--full-scale-volts must be"),
])
def test_incomplete_or_conflicting_calibration_is_one_line(tmp_path, capsys, args, needle):
    src = _recorded_tone(tmp_path / "tone.flac", "FLAC", "PCM_16", seconds=0.1, n_ch=1)
    out = tmp_path / "rec.h5"
    assert main(["import", str(src), "-o", str(out), *args]) == 2
    err = capsys.readouterr().err
    assert err.startswith("arrayproc: error:") and needle in err and err.count("\n") == 1
    assert not out.exists()


def test_an_unreadable_audio_file_is_one_line(tmp_path, capsys):
    bad = tmp_path / "x.flac"
    bad.write_bytes(b"not audio at all")
    assert main(["import", str(bad), "-o", str(tmp_path / "r.h5")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("arrayproc: error:") and "x.flac" in err


def test_flat_sensitivity_factor():
    # -170 dB re 1 V/µPa + 20 dB gain, 2 V full scale: 1 FS = 2 V = 2 / 10^(-7.5) µPa
    assert pascals_per_full_scale(SENS, GAIN, VFS) == pytest.approx(2e-6 / 10 ** -7.5)


def test_a_response_sheet_corrects_each_frequency(tmp_path):
    """Two tones where the sheet differs by 10 dB both read their true pressure, aligned and
    of the input's length through the streaming filter."""
    freq = np.array([0.0, 500.0, 1500.0, 4000.0])
    sens = np.array([-170.0, -170.0, -160.0, -160.0])
    fs, n = 8000.0, 24000
    t = np.arange(n) / fs
    f1, f2 = 250.0, 2500.0
    p = np.sin(2 * np.pi * f1 * t) + np.sin(2 * np.pi * f2 * t)  # Pa, 1/√2 Pa RMS each
    volts = 1e6 * (np.sin(2 * np.pi * f1 * t) * 10 ** (-170 / 20)
                   + np.sin(2 * np.pi * f2 * t) * 10 ** (-160 / 20))
    x = (volts / VFS)[:, None]
    filt = ResponseFilter(freq, sens, fs, 0.0, VFS)
    y = np.concatenate([filt.process(x[s:s + 5000]) for s in range(0, n, 5000)]
                       + [filt.flush()])
    assert y.shape == (n, 1)
    mid = slice(2000, n - 2000)  # away from the filter's start-up at both ends
    assert np.max(np.abs(y[mid, 0] - p[mid])) < 1e-3 * np.max(np.abs(p))


def test_a_response_sheet_through_the_cli_reads_the_same_120_db(tmp_path):
    """The sheet's sensitivity at the tone is the stated one (−170 dB; −160 dB far above):
    the level after `import --response` is 120 dB re 1 µPa too."""
    src = _recorded_tone(tmp_path / "tone.flac", "FLAC", "PCM_24")
    sheet = tmp_path / "sheet.csv"
    sheet.write_text("freq_hz,sensitivity_db\n10,-170\n1500,-170\n3000,-160\n",
                     encoding="utf-8")
    rec, prod = tmp_path / "rec.h5", tmp_path / "p.h5"
    assert main(["import", str(src), "-o", str(rec), "--line", "2", "0.5", "--response",
                 str(sheet), "--gain", str(GAIN), "--full-scale-volts", str(VFS), "-q"]) == 0
    with Recording(rec) as r:
        assert r.n_samples == int(4.0 * FS)  # the FIR's delay removed, the length kept
        assert "frequency response sheet.csv" in r._td.attrs["calibration"]
    assert main(["process", str(rec), "-c", str(_power_chain(tmp_path)), "-o", str(prod),
                 "-q", "--no-progress"]) == 0
    level = read_products(prod)["power"]["power_db"]
    assert np.all(np.abs(level[1:-1] - 120.0) < 0.1), level  # inner blocks: no start-up
