"""No silent wrong outputs, through the real command line (``arrayproc.app.cli.main``): each
case ran with exit 0 and a wrong or unusable result before, and now gives the right result, a
one-line warning, or a one-line refusal with exit 2."""

from __future__ import annotations

import subprocess
import sys
import wave

import h5py
import numpy as np
import pytest

from arrayproc.app.cli import main
from arrayproc.data import data_path
from arrayproc.io.geometry import line_array
from arrayproc.io.products import ProductsWriter, read_products
from tests.conftest import REPO, cbf_stage, chain_toml, write_recording

FS = 1000.0


def _err(capsys) -> list[str]:
    return capsys.readouterr().err.strip().splitlines()


def _warnings(lines: list[str]) -> list[str]:
    return [ln for ln in lines if ln.startswith("arrayproc: warning:")]


@pytest.fixture
def noise_rec(tmp_path, rng):
    """8 hydrophones 0.5 m apart along body x, white noise (no source: nothing to detect)."""
    x = rng.standard_normal((8192, 8)).astype(np.float32)
    return write_recording(tmp_path / "r.h5", x, fs=FS, positions=line_array(8, 0.5))


def _passive_chain(tmp_path, band=(100.0, 400.0), threshold_db=30.0, name="c.toml") -> str:
    p = tmp_path / name
    p.write_text(chain_toml(cbf_stage(256, list(band), 19), {"type": "integrate",
                            "snapshots": 2}, {"type": "btr"},
                            {"type": "bearings", "input": "integrate",
                             "threshold_db": threshold_db}))
    return str(p)


def _process(rec, chain, out) -> int:
    return main(["process", str(rec), "-c", str(chain), "-o", str(out), "--no-progress", "-q"])


# -- 1. info: rows apart from axis lengths ------------------------------------------------------
def test_info_reports_rows_not_axis_lengths(tmp_path, capsys):
    p = tmp_path / "p.h5"
    with ProductsWriter(p) as w:
        g = w.group("btr", "btr")
        g.set("cone_deg", np.linspace(0.0, 180.0, 181))
        g.append(time=np.arange(89.0), power_db=np.zeros((89, 181), np.float32))
    assert main(["info", str(p)]) == 0
    out = capsys.readouterr().out
    assert "btr: kind=btr rows=89 columns=power_db, time axes=cone_deg (181)" in out, out


# -- 2. an empty result is a valid empty table --------------------------------------------------
def test_bearings_that_find_nothing_give_a_valid_empty_table(tmp_path, noise_rec, capsys):
    out = tmp_path / "p.h5"
    assert _process(noise_rec, _passive_chain(tmp_path), out) == 0
    g = read_products(out)["bearings"]
    from arrayproc.io.schema import KINDS
    for col in KINDS["bearings"].required():
        assert g[col].shape == (0,) and g[col].dtype == np.float64, col
    assert main(["info", str(out)]) == 0
    assert "bearings: kind=bearings rows=0 columns=bearing_port_deg" in capsys.readouterr().out


def test_export_and_track_handle_an_empty_bearings_table(tmp_path, noise_rec, capsys):
    prod = tmp_path / "p.h5"
    assert _process(noise_rec, _passive_chain(tmp_path), prod) == 0
    assert main(["export", "--to", "raven", "-o", str(tmp_path / "sel.txt"), str(prod)]) == 0
    rows = (tmp_path / "sel.txt").read_text().strip().splitlines()
    assert len(rows) == 1 and rows[0].startswith("Selection")  # header, no selections
    capsys.readouterr()
    for tracker in ("ukf_lr.toml", "multi_target.toml"):
        tracks = tmp_path / f"t_{tracker}.h5"
        rc = main(["track", str(prod), "-c", str(data_path("trackers", tracker)), "-o",
                   str(tracks), "--no-progress"])
        cap = capsys.readouterr()
        assert rc == 0, cap.err
        assert "no tracks" in cap.out and "empty tracks table" in cap.out
        g = read_products(tracks)["tracks"]
        assert g["time"].shape == (0,) and g["cov"].shape == (0, 4, 4)
        assert g["track_id"].dtype == np.int64
        assert "Traceback" not in cap.err


def test_old_file_with_a_columnless_group_is_read_as_empty(tmp_path, capsys):
    """A products file from before the fix: the bearings group has no datasets at all."""
    p = tmp_path / "old.h5"
    with ProductsWriter(p) as w:
        w.group("bearings", "bearings")
    with h5py.File(p, "a") as f:
        for k in list(f["bearings"]):
            del f["bearings"][k]
    assert read_products(p)["bearings"]["time"].shape == (0,)
    assert main(["export", "--to", "raven", "-o", str(tmp_path / "s.txt"), str(p)]) == 0


# -- 3. a band above Nyquist is refused ---------------------------------------------------------
@pytest.mark.parametrize("stage", [
    cbf_stage(256, [100.0, 800.0], 19),
    {"type": "power", "band": [100.0, 800.0]},
    {"type": "ibf", "snapshot": "nfft", "nfft": 256, "band": [100.0, 800.0]},
    {"type": "etam", "snapshot": "nfft", "nfft": 256, "band": [100.0, 800.0], "snapshots": 2},
], ids=["cbf", "power", "ibf", "etam"])
def test_band_above_nyquist_is_refused(tmp_path, noise_rec, capsys, stage):
    chain = tmp_path / "c.toml"
    chain.write_text(chain_toml(stage))
    out = tmp_path / "o.h5"
    assert _process(noise_rec, chain, out) == 2
    err = _err(capsys)
    assert len(err) == 1 and err[0].startswith("arrayproc: error:"), err
    assert "key 'band' upper edge 800 Hz is above the Nyquist frequency 500 Hz" in err[0]
    assert not out.exists()


# -- 6. a line along y warns --------------------------------------------------------------------
def test_line_array_along_y_warns(tmp_path, rng, capsys):
    pos = line_array(8, 0.5)[:, [1, 0, 2]]  # the same line, laid along body y
    rec = write_recording(tmp_path / "y.h5", rng.standard_normal((4096, 8)).astype(np.float32),
                          fs=FS, positions=pos)
    assert _process(rec, _passive_chain(tmp_path), tmp_path / "o.h5") == 0
    w = _warnings(_err(capsys))
    assert len(w) == 1, w
    assert "cone-angle beams assume a line array along body x" in w[0]
    assert "3.5 m along y and 0 m along x" in w[0]


def test_line_array_along_x_does_not_warn(tmp_path, noise_rec, capsys):
    assert _process(noise_rec, _passive_chain(tmp_path), tmp_path / "o.h5") == 0
    assert _warnings(_err(capsys)) == []


# -- 7. a band above the spatial-aliasing limit warns -------------------------------------------
def test_band_above_spatial_aliasing_limit_warns(tmp_path, rng, capsys):
    rec = write_recording(tmp_path / "w.h5", rng.standard_normal((4096, 8)).astype(np.float32),
                          fs=FS, positions=line_array(8, 2.0))  # c/(2d) = 375 Hz
    assert _process(rec, _passive_chain(tmp_path), tmp_path / "o.h5") == 0
    w = _warnings(_err(capsys))
    assert len(w) == 1, w
    assert "above the array's spatial-aliasing limit c/(2d) = 375 Hz (d = 2 m" in w[0]
    # the same array below the limit: silent
    assert _process(rec, _passive_chain(tmp_path, band=(100.0, 350.0)), tmp_path / "o2.h5") == 0
    assert _warnings(_err(capsys)) == []


def test_synthetic_aperture_band_above_aliasing_limit_warns(tmp_path, rng, capsys):
    rec = write_recording(tmp_path / "w.h5", rng.standard_normal((4096, 8)).astype(np.float32),
                          fs=FS, positions=line_array(8, 2.0))
    chain = tmp_path / "c.toml"
    chain.write_text(chain_toml({"type": "psas", "snapshot": "nfft", "nfft": 256,
                                 "band": [100.0, 450.0], "snapshots": 2,
                                 "beams": {"start": 0.0, "stop": 180.0, "count": 19}}))
    assert _process(rec, chain, tmp_path / "o.h5") == 0
    w = _warnings(_err(capsys))
    assert len(w) == 1 and "stage 'psas': key 'band' reaches 450 Hz" in w[0], w


# -- 4. the unit is carried to products and labels ----------------------------------------------
def _write_wavs(tmp_path, names, rng, n=4096, noise=2000.0):
    """Mono 16-bit WAV files; file i holds 100·(i + 1) counts plus noise."""
    for i, name in enumerate(names):
        with wave.open(str(tmp_path / name), "wb") as w:
            w.setnchannels(1)
            w.setsampwidth(2)
            w.setframerate(int(FS))
            w.writeframes((np.full(n, 100 * (i + 1)) + rng.normal(0, noise, n))
                          .astype("<i2").tobytes())


def _colorbar_label(png_args, monkeypatch) -> str:
    """The colour-bar label of the plot the CLI draws (captured from matplotlib)."""
    from matplotlib.colorbar import Colorbar
    seen = []
    orig = Colorbar.set_label
    monkeypatch.setattr(Colorbar, "set_label",
                        lambda self, label, **kw: (seen.append(label), orig(self, label, **kw)))
    assert main(png_args) == 0
    return seen[-1]


@pytest.mark.parametrize("scale,units,label", [(None, "FS", "dB re FS²"),
                                               (10.0, "Pa", "dB re 1 µPa²")])
def test_imported_units_reach_products_and_plot_labels(tmp_path, rng, capsys, monkeypatch,
                                                       scale, units, label):
    names = [f"h{i}.wav" for i in range(1, 9)]
    _write_wavs(tmp_path, names, rng)
    rec = tmp_path / "rec.h5"
    args = ["import", *[str(tmp_path / n) for n in names], "-o", str(rec), "--line", "8",
            "0.5", "-q"]
    assert main(args + ([] if scale is None else ["--scale", str(scale)])) == 0
    with h5py.File(rec) as f:
        assert f["time_data"].attrs["units"] == units
    prod = tmp_path / "p.h5"
    assert _process(rec, _passive_chain(tmp_path), prod) == 0
    assert read_products(prod)["/"]["units"] == units
    got = _colorbar_label(["plot", str(prod), "-o", str(tmp_path / "btr.png")], monkeypatch)
    assert label in got, got
    assert ("µPa" in got) == (units == "Pa")
    assert main(["info", str(prod)]) == 0
    assert f"units: {units}" in capsys.readouterr().out


def test_full_scale_levels_are_re_full_scale(tmp_path, rng):
    """Full-scale data: the BTR level is 10 log10(power / 1²), not re 1 µPa (+120 dB)."""
    x = rng.standard_normal((8192, 8)).astype(np.float32)
    out = {}
    for units in ("Pa", "FS"):
        rec = write_recording(tmp_path / f"{units}.h5", x, fs=FS, positions=line_array(8, 0.5),
                              units=units)
        prod = tmp_path / f"p{units}.h5"
        assert _process(rec, _passive_chain(tmp_path), prod) == 0
        out[units] = read_products(prod)["btr"]["power_db"].astype(float)
    # same samples, references 1e-6 and 1: 20 log10(1e6) = 120 dB apart (float32 storage)
    np.testing.assert_allclose(out["Pa"] - out["FS"], 120.0, atol=1e-4)


def test_recording_without_units_attribute_reads_as_pascals(tmp_path, rng):
    rec = write_recording(tmp_path / "r.h5", rng.standard_normal((4096, 8)).astype(np.float32),
                          fs=FS, positions=line_array(8, 0.5), units="FS")
    with h5py.File(rec, "a") as f:
        del f["time_data"].attrs["units"]
    prod = tmp_path / "p.h5"
    assert _process(rec, _passive_chain(tmp_path), prod) == 0
    assert read_products(prod)["/"]["units"] == "Pa"


def test_level_tracker_refuses_full_scale_levels(tmp_path, rng, capsys):
    rec = write_recording(tmp_path / "r.h5", rng.standard_normal((4096, 8)).astype(np.float32),
                          fs=FS, positions=line_array(8, 0.5), units="FS")
    prod = tmp_path / "p.h5"
    assert _process(rec, _passive_chain(tmp_path, threshold_db=0.5), prod) == 0
    cfg = tmp_path / "t.toml"
    cfg.write_text(data_path("trackers", "ukf_lr.toml").read_text()
                   .replace("[tracker]", '[tracker]\nlevel = "level_db"', 1))
    capsys.readouterr()
    assert main(["track", str(prod), "-c", str(cfg), "-o", str(tmp_path / "t.h5")]) == 2
    err = _err(capsys)
    assert len(err) == 1 and "dB re FS" in err[0], err


# -- 5. WAV files in the natural order of their names -------------------------------------------
def test_import_sorts_wavs_naturally_with_a_notice(tmp_path, rng, capsys):
    names = [f"hyd{i}.wav" for i in range(1, 13)]
    _write_wavs(tmp_path, names, rng, n=256, noise=0.0)
    shell = sorted(names)  # hyd1, hyd10, hyd11, hyd12, hyd2, ...: what the shell's glob gives
    rec = tmp_path / "r.h5"
    assert main(["import", *[str(tmp_path / n) for n in shell], "-o", str(rec), "-q"]) == 0
    w = _warnings(_err(capsys))
    assert len(w) == 1 and "natural order of the file names (hyd1.wav, hyd2.wav" in w[0], w
    with h5py.File(rec) as f:
        means = f["time_data"][()].mean(axis=0)
    # channel k holds file hyd{k+1}, 100·(k+1) counts (float32 mean of 256 equal values)
    np.testing.assert_allclose(means * 32768, 100 * np.arange(1, 13), rtol=1e-6)
    # already in natural order: no notice
    assert main(["import", *[str(tmp_path / n) for n in names], "-o",
                 str(tmp_path / "r2.h5"), "-q"]) == 0
    assert _warnings(_err(capsys)) == []


def test_import_refuses_an_ambiguous_order(tmp_path, rng, capsys):
    _write_wavs(tmp_path, ["stbd.wav", "port.wav"], rng, n=64)
    out = tmp_path / "r.h5"
    assert main(["import", str(tmp_path / "stbd.wav"), str(tmp_path / "port.wav"), "-o",
                 str(out)]) == 2
    err = _err(capsys)
    assert len(err) == 1 and "channel order of the WAV files is ambiguous" in err[0], err
    assert not out.exists()


# -- 8. an unknown stage type lists every type --------------------------------------------------
def test_unknown_stage_type_lists_every_type(tmp_path, noise_rec):
    """In a fresh process (the test session has every stage loaded already)."""
    from arrayproc.stages import TYPES
    chain = tmp_path / "c.toml"
    chain.write_text('[[stage]]\ntype = "cbff"\n')
    r = subprocess.run([sys.executable, "-m", "arrayproc", "process", str(noise_rec), "-c",
                        str(chain), "-o", str(tmp_path / "o.h5")], capture_output=True,
                       text=True, cwd=REPO)
    assert r.returncode == 2
    err = r.stderr.strip().splitlines()
    assert len(err) == 1 and "unknown stage type 'cbff'" in err[0], err
    known = err[0].split("(known: ", 1)[1].rstrip(")").split(", ")
    assert sorted(known) == sorted(TYPES)
