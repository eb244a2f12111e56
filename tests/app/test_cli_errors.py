"""Bad input through the real command line: one line `arrayproc: error: …`, exit 2, no
traceback, no output file left behind."""

from __future__ import annotations

import subprocess
import sys

import h5py
import numpy as np
import pytest

from arrayproc.app.cli import main
from arrayproc.io.geometry import line_array
from tests.conftest import write_recording

CHAIN = '[input]\nblock = 256\n[[stage]]\ntype = "power"\n'


@pytest.fixture
def good(tmp_path, rng):
    x = rng.standard_normal((2048, 4)).astype(np.float32)
    rec = write_recording(tmp_path / "rec.h5", x, positions=line_array(4, 0.5))
    chain = tmp_path / "chain.toml"
    chain.write_text(CHAIN)
    return rec, chain


def run_cli(args, capsys):
    rc = main([str(a) for a in args])
    err = capsys.readouterr().err.strip().splitlines()
    return rc, err


def check_error(tmp_path, args, capsys, match, out_name="out.h5"):
    before = set(tmp_path.iterdir())
    rc, err = run_cli(args, capsys)
    assert rc == 2
    assert len(err) == 1 and err[0].startswith("arrayproc: error:"), err
    assert match in err[0], err[0]
    assert set(tmp_path.iterdir()) <= before  # nothing new, not even a temporary file
    assert not (tmp_path / out_name).exists()


def process_args(tmp_path, rec, chain):
    return ["process", rec, "-c", chain, "-o", tmp_path / "out.h5", "--no-progress"]


def test_missing_file(tmp_path, good, capsys):
    _, chain = good
    check_error(tmp_path, process_args(tmp_path, tmp_path / "nope.h5", chain), capsys,
                "nope.h5: no such recording")


def test_not_hdf5(tmp_path, good, capsys):
    _, chain = good
    bad = tmp_path / "text.h5"
    bad.write_text("hello")
    check_error(tmp_path, process_args(tmp_path, bad, chain), capsys, "text.h5: not an HDF5")


def test_truncated_hdf5(tmp_path, good, capsys):
    rec, chain = good
    data = rec.read_bytes()
    cut = tmp_path / "cut.h5"
    cut.write_bytes(data[: len(data) // 2])
    check_error(tmp_path, process_args(tmp_path, cut, chain), capsys, "cut.h5")


def test_no_time_data(tmp_path, good, capsys):
    _, chain = good
    p = tmp_path / "empty.h5"
    with h5py.File(p, "w") as f:
        f["other"] = np.zeros(3)
    check_error(tmp_path, process_args(tmp_path, p, chain), capsys, "no /time_data")


def test_one_dimensional_time_data(tmp_path, good, capsys):
    _, chain = good
    p = tmp_path / "flat.h5"
    with h5py.File(p, "w") as f:
        f.create_dataset("time_data", data=np.zeros(100)).attrs["sample_freq"] = 100.0
    check_error(tmp_path, process_args(tmp_path, p, chain), capsys, "must be 2-D")


def test_positions_row_count(tmp_path, good, capsys, rng):
    _, chain = good
    p = write_recording(tmp_path / "pos.h5", rng.standard_normal((100, 4)).astype(np.float32),
                        positions=line_array(3, 1.0))
    check_error(tmp_path, process_args(tmp_path, p, chain), capsys,
                "array positions have 3 rows but /time_data has 4 channels")


def test_nav_time_not_increasing(tmp_path, good, capsys, rng):
    _, chain = good
    nav = dict(time=np.array([0.0, 1.0, 1.0]), position=np.zeros((3, 2)),
               heading=np.zeros(3))
    p = write_recording(tmp_path / "nav.h5", rng.standard_normal((100, 4)).astype(np.float32),
                        positions=line_array(4, 1.0), nav=nav)
    check_error(tmp_path, process_args(tmp_path, p, chain), capsys,
                "/nav/time is not strictly increasing")


def test_nan_samples_error_then_zero_with_warning(tmp_path, good, capsys, rng):
    _, chain = good
    x = rng.standard_normal((1000, 4)).astype(np.float32)
    x[700, 2] = np.nan
    x[10, 0] = np.inf
    p = write_recording(tmp_path / "nan.h5", x, positions=line_array(4, 1.0))
    check_error(tmp_path, process_args(tmp_path, p, chain), capsys, "NaN or Inf sample at sample")
    rc, err = run_cli(process_args(tmp_path, p, chain) + ["--nan", "zero"], capsys)
    assert rc == 0 and (tmp_path / "out.h5").exists()
    assert any("2 NaN/Inf samples replaced by zeros" in e for e in err)


def test_unknown_stage_type(tmp_path, good, capsys):
    rec, _ = good
    c = tmp_path / "bad.toml"
    c.write_text('[[stage]]\ntype = "beamform"\n')
    check_error(tmp_path, process_args(tmp_path, rec, c), capsys,
                "unknown stage type 'beamform'")


def test_unknown_stage_key(tmp_path, good, capsys):
    rec, _ = good
    c = tmp_path / "bad.toml"
    c.write_text('[[stage]]\ntype = "power"\nbnd = [1.0, 2.0]\n')
    check_error(tmp_path, process_args(tmp_path, rec, c), capsys, "bad.toml: stage 'power': "
                "unknown key 'bnd'")


def test_output_directory_missing(tmp_path, good, capsys):
    rec, chain = good
    args = ["process", rec, "-c", chain, "-o", tmp_path / "no" / "out.h5"]
    check_error(tmp_path, args, capsys, "output directory")


def test_error_in_a_subprocess_has_no_traceback(tmp_path):
    """The installed entry point: exit status 2, a single line on stderr."""
    r = subprocess.run([sys.executable, "-m", "arrayproc.app.cli", "info", str(tmp_path / "x.h5")],
                       capture_output=True, text=True)
    assert r.returncode == 2
    assert r.stderr.strip().splitlines() == [f"arrayproc: error: {tmp_path / 'x.h5'}: no such file"]
    assert "Traceback" not in r.stderr


def test_info_on_recording_and_products(tmp_path, good, capsys):
    rec, chain = good
    assert main(["info", str(rec)]) == 0
    out = capsys.readouterr().out
    assert "format version 1" in out and "channels: 4 active of 4" in out and "line" in out
    assert main([str(a) for a in process_args(tmp_path, rec, chain)]) == 0
    assert main(["info", str(tmp_path / "out.h5")]) == 0
    out = capsys.readouterr().out
    assert "power: kind=power rows=8" in out


def test_closed_pipe_is_quiet(tmp_path, good):
    """`arrayproc info FILE | head -1`: no traceback when the reader goes away."""
    rec, _ = good
    r = subprocess.run(f"{sys.executable} -m arrayproc.app.cli info {rec} | head -1", shell=True,
                       capture_output=True, text=True)
    assert r.stdout.count("\n") == 1 and "Traceback" not in r.stderr
