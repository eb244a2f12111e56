"""What must keep working or warn: warnings as one line, plots in the format the
extension names, ``info`` on any file (acoular layout without geometry, 8,000 channels), writers
that never leak a temporary file, a swallowed interrupt that still stops the writers, truncated
WAV files imported with a warning, and the chain memory estimate."""

from __future__ import annotations

import signal
import subprocess
import sys
import wave

import h5py
import numpy as np
import pytest

from arrayproc.app.cli import main
from arrayproc.app.resources import estimate_chain_bytes
from arrayproc.config import tomllib
from arrayproc.data import data_path
from arrayproc.errors import FormatError, Interrupted
from arrayproc.io.atomic import clear_stop, request_stop
from arrayproc.io.geometry import aperture, line_array
from arrayproc.io.products import ProductsWriter
from arrayproc.io.recording import RecordingWriter
from tests.conftest import write_recording


def _stderr_lines(capsys) -> list[str]:
    return capsys.readouterr().err.strip().splitlines()


def test_warnings_print_as_one_arrayproc_line(tmp_path, rng, capsys):
    rec = write_recording(tmp_path / "r.h5", rng.standard_normal((4096, 4)).astype(np.float32),
                          positions=line_array(4, 0.5))
    chain = tmp_path / "c.toml"
    chain.write_text('[[stage]]\ntype = "cbf"\nnfft = 64\nhop = 96\n'
                     'beams = {start = 0.0, stop = 180.0, count = 5}\n')
    rc = main(["process", str(rec), "-c", str(chain), "-o", str(tmp_path / "o.h5"),
               "--no-progress", "-q"])
    lines = _stderr_lines(capsys)
    assert rc == 0
    assert len(lines) == 1 and lines[0].startswith("arrayproc: warning: stage 'cbf': key 'hop'")


@pytest.fixture
def btr_products(tmp_path):
    p = tmp_path / "p.h5"
    with ProductsWriter(p) as w:
        g = w.group("btr", "btr")
        g.set("cone_deg", np.linspace(0.0, 180.0, 19))
        g.append(time=np.arange(6.0), power_db=np.random.default_rng(1).normal(size=(6, 19)))
    return p


@pytest.mark.parametrize("ext,magic", [("pdf", b"%PDF"), ("svg", b"<?xml"), ("png", b"\x89PNG")])
def test_plot_writes_the_format_its_extension_names(tmp_path, btr_products, ext, magic, capsys):
    out = tmp_path / f"x.{ext}"
    assert main(["plot", str(btr_products), "-o", str(out)]) == 0
    assert out.read_bytes().startswith(magic)
    assert sorted(q.name for q in tmp_path.iterdir()) == ["p.h5", f"x.{ext}"]


def test_info_describes_acoular_layout_without_geometry(tmp_path, capsys):
    p = tmp_path / "ac.h5"
    with h5py.File(p, "w") as f:
        f.create_dataset("time_data", data=np.zeros((5000, 8), np.float32)).attrs[
            "sample_freq"] = 2000.0
    assert main(["info", str(p)]) == 0
    out = capsys.readouterr().out
    assert "acoular layout" in out and "channels: 8 active of 8" in out
    assert "sample rate: 2000 Hz" in out and "duration: 2.500 s" in out
    assert "--line N SPACING" in out and "--geometry FILE" in out


def test_info_on_8000_channels_is_cheap(tmp_path):
    """Peak memory of `info` on a small file with 8,000 channels (it took 3.5 GB once)."""
    p = tmp_path / "wide.h5"
    pos = np.zeros((8000, 3))
    pos[:, 0] = np.arange(8000) * 0.1
    pos[:, 1] = np.sin(np.arange(8000))
    with RecordingWriter(p, 1000.0, 8000, positions=pos, chunk_samples=2) as w:
        w.append(np.zeros((2, 8000), np.float32))
    # VmHWM (this process's peak RSS, kB), not ru_maxrss: Linux carries the parent's peak
    # into ru_maxrss across fork + exec, so under pytest it would measure pytest.
    code = ("import sys\nfrom arrayproc.app.cli import main\n"
            f"rc = main(['info', {str(p)!r}])\n"
            "hwm = [ln for ln in open('/proc/self/status') if ln.startswith('VmHWM')][0]\n"
            "print('peak', hwm.split()[1])\nsys.exit(rc)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "channels: 8000 active of 8000" in r.stdout and "planar" in r.stdout
    peak_kib = int(r.stdout.split("peak")[1])
    assert peak_kib < 400_000  # 400 MB; the n x n x 3 pair array alone was 1.5 GB


def test_aperture_in_chunks_equals_all_pairs():
    pos = np.random.default_rng(3).normal(size=(300, 3))
    d = pos[:, None, :] - pos[None, :, :]
    assert aperture(pos, chunk_pairs=1000) == pytest.approx(np.sqrt((d**2).sum(-1)).max(),
                                                            rel=1e-15)


def test_writer_whose_setup_fails_leaves_no_temporary_file(tmp_path):
    with pytest.raises(FormatError, match="sample rate"):
        RecordingWriter(tmp_path / "x.h5", float("nan"), 4)
    with pytest.raises(FormatError, match="sound speed"):
        RecordingWriter(tmp_path / "x.h5", 1000.0, 4, sound_speed=0.0)
    assert list(tmp_path.iterdir()) == []


def test_swallowed_interrupt_still_stops_the_writers(tmp_path):
    """A signal whose exception Python drops (raised inside a weakref callback) still stops
    the run at the next write and the output is never committed."""
    w = RecordingWriter(tmp_path / "x.h5", 1000.0, 2)
    w.append(np.zeros((10, 2), np.float32))
    request_stop(signal.SIGINT)  # what the handler records before its exception is lost
    try:
        with pytest.raises(Interrupted):
            w.append(np.zeros((10, 2), np.float32))
        with pytest.raises(Interrupted):
            w.close()
    finally:
        clear_stop()
    assert list(tmp_path.iterdir()) == []


def test_truncated_wav_imports_with_a_warning(tmp_path, capsys):
    p = tmp_path / "t.wav"
    with wave.open(str(p), "wb") as w:
        w.setnchannels(2)
        w.setsampwidth(2)
        w.setframerate(8000)
        w.writeframes(np.zeros((1000, 2), "<i2").tobytes())
    p.write_bytes(p.read_bytes()[:-1000])  # 250 frames cut off the end
    rc = main(["import", str(p), "-o", str(tmp_path / "o.h5"), "--line", "2", "0.5", "-q"])
    lines = _stderr_lines(capsys)
    assert rc == 0
    assert lines == [f"arrayproc: warning: {p}: truncated WAV: the header declares 1000 "
                     "samples, the file holds 750; importing those"]


def test_chain_memory_estimate_scales_with_beams():
    cfg = tomllib.loads((data_path() / "chains" / "towed_passive.toml").read_text())
    total = sum(b for _, b in estimate_chain_bytes(cfg, 32, 2048.0))
    assert 1 << 20 < total < 1 << 30  # the demo chain: MBs, not GBs
    cfg["stage"][1]["beams"]["count"] = 100_000_000
    assert sum(b for _, b in estimate_chain_bytes(cfg, 32, 2048.0)) > 1 << 40
