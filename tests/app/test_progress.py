"""The end-of-command summary line and the progress bar in seconds of audio
(arrayproc/app/progress.py): what was written, how long it took and the multiple of real time,
on stdout when it is not a terminal; ``-q`` prints nothing."""

from __future__ import annotations

import re
import subprocess
import sys
import time

import numpy as np
import pytest

from arrayproc.app.cli import main
from arrayproc.app.progress import (
    AudioBar,
    Summary,
    audio_seconds,
    format_ratio,
    format_seconds,
    peak_memory_mb,
    summary_line,
)
from arrayproc.io.geometry import line_array
from tests.conftest import chain_toml, write_recording

LINE = re.compile(r"^arrayproc: wrote (?P<out>\S+) \((?P<what>[^)]*)\) in (?P<t>[\d.]+) s"
                  r"(?:, (?P<x>[\d.e+-]+)x real time)?, peak (?P<mb>\d+) MB$")

SCENARIO = """[recording]
fs = 1024.0
duration = 3.0
seed = 7
[array]
type = "line"
n = 4
spacing = 0.5
[ownship]
start = [0.0, 0.0]
course = 90.0
speed = 2.0
[[source]]
name = "a"
start = [300.0, 400.0]
tonals = [{ freq = 200.0, level_db = 140.0 }]
[noise]
level_db = 60.0
"""


@pytest.fixture
def rec(tmp_path, rng):
    """A 4 s, 4-channel recording at 1000 Hz and a power chain of 250-sample blocks."""
    x = rng.standard_normal((4000, 4)).astype(np.float32)
    path = write_recording(tmp_path / "rec.h5", x, positions=line_array(4, 0.5))
    chain = tmp_path / "chain.toml"
    chain.write_text(chain_toml({"type": "power", "band": [50.0, 400.0]}, block=250))
    return path, chain


def summary_of(out: str) -> re.Match:
    lines = out.strip().splitlines()
    assert len(lines) == 1, lines
    m = LINE.match(lines[0])
    assert m, lines[0]
    return m


def check_ratio(m: re.Match, audio_s: float, wall_max: float) -> None:
    """The ratio is the audio's duration over the printed time (to the printed digits), and
    the printed time is no longer than the call took."""
    t, x = float(m["t"]), float(m["x"])
    assert 0 < t <= wall_max + 0.05
    assert x == pytest.approx(audio_s / t, rel=0.06)  # t and x are printed to 2-3 digits


def test_process_summary_line(tmp_path, rec, capsys):
    path, chain = rec
    t0 = time.perf_counter()
    rc = main(["process", str(path), "-c", str(chain), "-o", str(tmp_path / "p.h5"),
               "--no-progress"])
    wall = time.perf_counter() - t0
    assert rc == 0
    m = summary_of(capsys.readouterr().out)
    assert m["out"] == str(tmp_path / "p.h5")
    assert m["what"] == "1 group, 16 blocks"       # 4000 samples in blocks of 250
    check_ratio(m, 4.0, wall)


def test_simulate_summary_line(tmp_path, capsys):
    scn = tmp_path / "s.toml"
    scn.write_text(SCENARIO)
    t0 = time.perf_counter()
    assert main(["simulate", str(scn), "-o", str(tmp_path / "s.h5"), "--no-progress"]) == 0
    wall = time.perf_counter() - t0
    m = summary_of(capsys.readouterr().out)
    assert m["what"] == "4 channels, 3 s at 1024 Hz"
    check_ratio(m, 3.0, wall)


def test_quiet_prints_no_summary(tmp_path, rec, capsys):
    path, chain = rec
    assert main(["process", str(path), "-c", str(chain), "-o", str(tmp_path / "p.h5"),
                 "-q"]) == 0
    out = capsys.readouterr()
    assert out.out == "" and out.err == ""


def test_audio_seconds_follow_the_products_source(tmp_path, rec):
    """The summary of a file made from products (track, tma, export) knows the recording's
    duration through its ``source`` / ``recording`` attributes; a file of no known audio gets
    no ratio."""
    path, chain = rec
    prod = tmp_path / "p.h5"
    assert main(["process", str(path), "-c", str(chain), "-o", str(prod), "-q"]) == 0
    assert audio_seconds(prod) == pytest.approx(4.0)
    assert audio_seconds(path) == pytest.approx(4.0)
    assert audio_seconds(chain) is None  # not HDF5: no audio, no error
    assert ", " not in summary_line("x.txt", "", 1.0, None)


def test_summary_through_a_pipe(tmp_path):
    """Stdout a pipe (not a terminal), as in a script or a batch job: one summary line."""
    scn = tmp_path / "s.toml"
    scn.write_text(SCENARIO)
    r = subprocess.run([sys.executable, "-m", "arrayproc", "simulate", str(scn), "-o",
                        str(tmp_path / "s.h5")], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    m = summary_of(r.stdout)
    assert m["out"] == str(tmp_path / "s.h5") and float(m["x"]) > 0
    assert r.stderr == ""  # no bar: stderr is not a terminal either


def test_formats():
    assert format_seconds(0.423) == "0.42 s"
    assert format_seconds(2.44) == "2.4 s"
    assert format_seconds(153.2) == "153 s"
    assert format_ratio(0.351) == "0.35x"
    assert format_ratio(4.24) == "4.2x"
    assert format_ratio(125.4) == "125x"
    assert summary_line("a.h5", "3 groups", 2.4, 300.0) == \
        "arrayproc: wrote a.h5 (3 groups) in 2.4 s, 125x real time"
    assert summary_line("a.h5", "3 groups", 2.4, 300.0, 412.4) == \
        "arrayproc: wrote a.h5 (3 groups) in 2.4 s, 125x real time, peak 412 MB"


def test_peak_memory_is_this_process_high_water_mark():
    import resource
    mb = peak_memory_mb()
    assert mb >= resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0 > 0


def test_summary_times_from_the_given_start():
    lines = []
    s = Summary(started=time.perf_counter() - 10.0, echo=lines.append)
    line = s("a.h5", "x", 100.0)
    assert lines == [line]
    t = float(LINE.match(line)["t"])
    assert 10.0 <= t < 11.0
    assert Summary(quiet=True, echo=lines.append)("b.h5") and len(lines) == 1


# -- progress in seconds of audio ---------------------------------------------------------------
def test_run_chain_reports_seconds_of_audio(rec):
    """``progress(done_s, total_s)`` after every block: done grows by block / fs and ends at
    the recording's duration (the last block partial: 4000 = 15 x 256 + 160)."""
    from arrayproc.app.api import load_chain, run_chain
    from arrayproc.io.recording import Recording
    path, chain = rec
    chain.write_text(chain_toml({"type": "power", "band": [50.0, 400.0]}, block=256))
    calls = []
    with Recording(path) as r:
        from arrayproc.chain.run import run_chain as run_inner
        n = run_inner(r, load_chain(str(chain)), progress=lambda d, t: calls.append((d, t)))
        assert run_chain(r, load_chain(str(chain)), progress=False) == n
    assert len(calls) == n == 16
    done = np.array([c[0] for c in calls])
    assert {c[1] for c in calls} == {4.0}
    np.testing.assert_allclose(done[:-1], np.arange(1, 16) * 0.256, rtol=1e-12)
    assert done[-1] == 4.0


def test_simulate_reports_seconds_of_audio(tmp_path):
    from arrayproc.sim.run import simulate
    from arrayproc.sim.scenario import load_scenario
    scn = tmp_path / "s.toml"
    scn.write_text(SCENARIO.replace("seed = 7", "seed = 7\nchunk = 1000"))
    calls = []
    simulate(load_scenario(scn), tmp_path / "s.h5", progress=lambda d, t: calls.append((d, t)))
    assert [c[1] for c in calls] == [3.0] * 4           # 3072 samples in chunks of 1000
    np.testing.assert_allclose([c[0] for c in calls], [1000 / 1024, 2000 / 1024,
                                                       3000 / 1024, 3.0], rtol=1e-12)


@pytest.mark.skipif(not hasattr(__import__("os"), "openpty"), reason="needs a pseudo-terminal")
def test_bar_on_a_terminal_counts_seconds_of_audio(tmp_path, rec):
    """stderr a terminal: ``process`` shows the bar in seconds of audio; stdout (a pipe)
    still gets the summary."""
    import os
    path, chain = rec
    master, slave = os.openpty()
    import fcntl
    import struct
    import termios
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 100, 0, 0))  # 100 columns
    try:
        r = subprocess.run([sys.executable, "-m", "arrayproc", "process", str(path), "-c",
                            str(chain), "-o", str(tmp_path / "p.h5")], stdout=subprocess.PIPE,
                           stderr=slave, text=True, timeout=300)
        os.close(slave)
        err = b""
        while True:
            try:
                chunk = os.read(master, 65536)
            except OSError:  # the other end closed
                break
            if not chunk:
                break
            err += chunk
    finally:
        os.close(master)
    assert r.returncode == 0
    assert "/4 s of audio" in err.decode(), err
    assert "block" not in err.decode()
    summary_of(r.stdout)


def test_audio_bar_counts_seconds(capsys):
    bar = AudioBar("process")
    bar(0.5, 4.0)
    bar(2.5, 4.0)
    bar(2.5, 4.0)           # no step: nothing added
    bar(9.0, 4.0)           # past the end: clipped to the total
    assert bar._bar.total == 4.0 and bar._bar.n == pytest.approx(4.0)
    assert bar._bar.unit == "s"
    text = str(bar._bar)
    assert "4/4 s of audio" in text, text
    bar.close()
    assert bar._bar is None
