"""``process --follow``: a recorder process appends to a recording in HDF5 SWMR mode while the
chain follows it; the live products equal, dataset for dataset and bit for bit, those of a run
on the finished file; the stream ends after ``--idle`` seconds without samples or at a
signal, with a complete file that could be read while it grew."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from arrayproc.app.commands import latency_line, process
from arrayproc.chain.reader import count_blocks
from arrayproc.evaluate import live_writer
from arrayproc.evaluate.compare import same_products
from arrayproc.evaluate.live_writer import wait_ready
from arrayproc.evaluate.scenarios.follow import BLOCK, follow_chain
from arrayproc.io.recording import Recording
from tests.conftest import REPO

WRITER = Path(live_writer.__file__)
ENV = dict(os.environ, PYTHONPATH=str(REPO))


def _writer(tmp_path: Path, seconds: float, hold: float = 0.0,
            nav: bool = False) -> tuple[subprocess.Popen, Path]:
    """The recorder, at twice real time once the follower's first rows are on disk."""
    rec, log = tmp_path / "rec.h5", tmp_path / "writer.json"
    w = subprocess.Popen([sys.executable, str(WRITER), str(rec), str(log), str(seconds), "0.2",
                          "0.1", str(hold), str(tmp_path / "live.h5")] + (["nav"] if nav else []),
                         stderr=subprocess.PIPE, text=True, env=ENV, cwd=REPO)
    assert wait_ready(w)
    return w, rec


def test_follow_equals_whole_file_run(tmp_path):
    chain = follow_chain(tmp_path)
    w, rec = _writer(tmp_path, 12.0)
    stats: list = []
    live = tmp_path / "live.h5"
    n = process(str(rec), str(chain), str(live), follow=True, idle_s=3.0, stats=stats)
    assert w.wait(60) == 0
    whole = tmp_path / "whole.h5"
    n_whole = process(str(rec), str(chain), str(whole))
    with Recording(rec) as r:
        assert n == n_whole == count_blocks(r, BLOCK, BLOCK) == r.n_samples // BLOCK + 1
    assert same_products(live, whole) == 7   # btr and lofar: time, beam, levels
    st = stats[0]
    assert st.reason.startswith("no new samples")
    lat = st.latencies()
    assert lat.size == n and np.all(lat >= 0)
    # the blocks went through while the recorder was writing, not all at its end
    written = json.loads((tmp_path / "writer.json").read_text())
    t_end = written[-1][1]
    assert np.sum(np.asarray(st.done) < t_end) >= n // 2
    assert "median" in latency_line(st)


def test_follow_with_a_growing_track(tmp_path, monkeypatch):
    """/nav grows with the samples: the follower re-reads it, every block waits until the
    track reaches the block's end, and the products equal the whole-file run's."""
    chain = follow_chain(tmp_path)
    w, rec = _writer(tmp_path, 10.0, nav=True)
    import arrayproc.chain.follow as FO
    ahead = []
    orig = FO.follow_blocks

    def spy(recording, *a, **k):
        for blk in orig(recording, *a, **k):
            ahead.append((recording.nav_end(), blk.t0 + blk.span, recording.growing))
            yield blk
    monkeypatch.setattr(FO, "follow_blocks", spy)
    live = tmp_path / "live.h5"
    process(str(rec), str(chain), str(live), follow=True, idle_s=3.0)
    assert w.wait(60) == 0
    whole = tmp_path / "whole.h5"
    process(str(rec), str(chain), str(whole))
    assert same_products(live, whole) == 7
    nav_end, block_end, growing = (np.array(v) for v in zip(*ahead))
    assert np.all(nav_end[growing] >= block_end[growing] - 1e-9)
    assert np.unique(nav_end).size > 5          # the track was re-read as it grew
    with Recording(rec) as r:
        assert r.nav.time.size == 51 and r.nav_end() == pytest.approx(10.0)


def test_follow_cli_stops_on_signal_with_a_complete_readable_file(tmp_path):
    chain = follow_chain(tmp_path)
    w, rec = _writer(tmp_path, 8.0, hold=6.0)   # the recorder goes quiet but keeps the file
    live = tmp_path / "live.h5"
    f = subprocess.Popen([sys.executable, "-m", "arrayproc", "process", str(rec), "-c",
                          str(chain), "-o", str(live), "--follow", "--idle", "120"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV,
                         cwd=REPO)
    grown = []
    deadline = time.monotonic() + 240
    while time.monotonic() < deadline:    # rows readable while the file grows (SWMR)
        time.sleep(0.2)
        try:
            with h5py.File(live, "r", libver="latest", swmr=True) as g:
                if "btr" in g and "time" in g["btr"]:
                    grown.append(int(g["btr/time"].shape[0]))
            with h5py.File(rec, "r", libver="latest", swmr=True) as r:
                if r["time_data"].shape[0] == 8000:
                    break
        except OSError:
            continue
    assert len(grown) >= 3 and 0 < grown[0] < grown[-1]   # seen growing
    f.send_signal(signal.SIGINT)
    out, err = f.communicate(timeout=120)
    assert f.returncode == 0, err
    assert "followed until signal 2" in out
    assert w.wait(60) == 0
    with h5py.File(live, "r") as g:
        assert bool(g.attrs["complete"])
    whole = tmp_path / "whole.h5"
    process(str(rec), str(chain), str(whole))
    assert same_products(live, whole) == 7   # btr and lofar: time, beam, levels


@pytest.mark.parametrize("args", [["--follow", "--idle", "0"], ["--follow", "--idle", "-1"],
                                  ["--follow", "--idle", "nan"], ["--idle", "5"]])
def test_follow_refuses_bad_idle(tmp_path, args):
    chain = follow_chain(tmp_path)
    rec = tmp_path / "r.h5"
    from tests.conftest import write_recording
    write_recording(rec, np.zeros((2000, 8), np.float32))
    p = subprocess.run([sys.executable, "-m", "arrayproc", "process", str(rec), "-c",
                        str(chain), "-o", str(tmp_path / "o.h5"), *args],
                       capture_output=True, text=True, env=ENV, cwd=REPO)
    assert p.returncode == 2 and p.stderr.startswith("arrayproc: error: --idle")
    assert len(p.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "o.h5").exists()


def test_signal_handler_in_a_live_run_ends_the_stream_then_stops():
    """The first signal of a --follow run is only recorded (the stream ends, the writers go
    on); a second one raises, and the run stops without output."""
    from arrayproc.app.cli import _on_signal
    from arrayproc.errors import Interrupted
    from arrayproc.io.atomic import check_stop, clear_stop, graceful, set_graceful
    clear_stop()
    set_graceful(True)
    try:
        assert _on_signal(signal.SIGINT, None) is None
        check_stop()              # no raise: the live products can still be finished
        with pytest.raises(Interrupted):
            _on_signal(signal.SIGTERM, None)
        assert not graceful()
        with pytest.raises(Interrupted):
            check_stop()
    finally:
        set_graceful(False)
        clear_stop()
