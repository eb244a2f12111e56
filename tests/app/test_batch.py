"""``arrayproc batch`` on a 2-worker LocalCluster: products equal to ``arrayproc
process`` bit for bit, segments merged into the single run, a worker killed mid-task, resume,
and a corrupt input failing alone."""

from __future__ import annotations

import os
import threading
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from arrayproc.app import batch
from arrayproc.app.api import run_chain
from arrayproc.chain.segments import plan_segments, warmup_margin
from arrayproc.io.geometry import line_array
from arrayproc.io.products import ProductsWriter
from arrayproc.io.recording import Recording
from tests.conftest import write_recording

distributed = pytest.importorskip("distributed")

FS = 2048.0
N_CH = 8
# dft_filter -> cbf (batches of 8 frames) -> blockwise integration -> BTR, LOFAR, bearings
CHAIN = """
[input]
block = 3000
[[stage]]
type = "dft_filter"
band = [100.0, 900.0]
[[stage]]
type = "cbf"
nfft = 256
hop = 128
band = [150.0, 850.0]
beams = { start = 0.0, stop = 180.0, count = 31 }
batch = 8
[[stage]]
type = "integrate"
snapshots = 4
[[stage]]
type = "btr"
input = "integrate"
[[stage]]
type = "lofar"
input = "integrate"
tpsw_window = 16
tpsw_gap = 2
[[stage]]
type = "bearings"
input = "integrate"
threshold_db = 3.0
"""
# the same chain without the overlap-save filter: every stage frames on the absolute grid
CHAIN_GRID = CHAIN.replace('type = "dft_filter"\nband = [100.0, 900.0]\n[[stage]]\n', "")


def make_recording(path: Path, seconds: float, seed: int) -> Path:
    """Noise plus a 400 Hz plane wave from cone angle 60 deg on an 8-element line array."""
    rng = np.random.default_rng(seed)
    n = int(seconds * FS)
    pos = line_array(N_CH, 0.75)
    t = np.arange(n) / FS
    tau = np.cos(np.deg2rad(60.0)) * (pos[:, 0] - pos[:, 0].mean()) / 1500.0
    x = 0.5 * rng.standard_normal((n, N_CH)) + np.sin(2 * np.pi * 400.0 * (t[:, None] - tau))
    return write_recording(path, x.astype(np.float32), fs=FS, positions=pos)


def datasets(path: Path) -> dict[str, object]:
    """Every dataset (values) and attribute of an HDF5 file, by path."""
    out: dict[str, object] = {}
    with h5py.File(path, "r") as f:
        out["/@"] = dict(f.attrs)

        def visit(name: str, obj: object) -> None:
            out[name + "@"] = dict(obj.attrs)
            if isinstance(obj, h5py.Dataset):
                out[name] = obj[()]
        f.visititems(visit)
    return out


def assert_same(a: Path, b: Path) -> None:
    """Every dataset bit for bit (NaNs equal) and every attribute equal."""
    da, db = datasets(a), datasets(b)
    assert da.keys() == db.keys()
    for k, va in da.items():
        vb = db[k]
        if isinstance(va, dict):
            assert va.keys() == vb.keys(), k
            for ak in va:
                assert np.array_equal(np.asarray(va[ak]), np.asarray(vb[ak])), (k, ak)
        else:
            assert va.dtype == vb.dtype and va.shape == vb.shape, k
            assert np.array_equal(va, vb, equal_nan=va.dtype.kind in "fc"), k


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                       dashboard_address=":0", silence_logs=50,
                                       env={v: "1" for v in batch.THREAD_VARS})
    c = distributed.Client(cluster)
    yield c
    c.close()
    cluster.close()


@pytest.fixture(scope="module")
def recs(tmp_path_factory) -> list[Path]:
    d = tmp_path_factory.mktemp("recs")
    return [make_recording(d / f"rec{i}.h5", 6.0, i) for i in range(3)]


@pytest.fixture(scope="module")
def chain_file(tmp_path_factory) -> Path:
    p = tmp_path_factory.mktemp("chain") / "chain.toml"
    p.write_text(CHAIN)
    return p


def test_three_recordings_equal_three_process_runs(tmp_path, client, recs, chain_file):
    from arrayproc.app.cli import main
    res = batch.run_batch(recs, chain_file, tmp_path / "out", client)
    assert [r.status for r in res] == ["done"] * 3
    for r in recs:
        ref = tmp_path / f"ref_{r.stem}.h5"
        assert main(["process", str(r), "-c", str(chain_file), "-o", str(ref), "-q",
                     "--no-progress"]) == 0
        assert_same(ref, tmp_path / "out" / f"{r.stem}.h5")
    # the same batch twice: the same datasets, no temporary files left
    res2 = batch.run_batch(recs, chain_file, tmp_path / "out2", client)
    assert [r.status for r in res2] == ["done"] * 3
    for r in recs:
        assert_same(tmp_path / "out" / f"{r.stem}.h5", tmp_path / "out2" / f"{r.stem}.h5")
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == \
        [f"{r.stem}.h5" for r in recs]


def single_run(rec: Path, text: str, out: Path) -> Path:
    spec = load_chain_text(text)
    with Recording(rec) as r, ProductsWriter(out, source=str(rec.resolve()),
                                             chain=spec.text) as w:
        run_chain(r, spec, w)
    return out


def load_chain_text(text: str):
    from arrayproc.app.api import build_chain
    return build_chain(text)


def test_segment_plan_partitions_the_recording():
    """Boundaries increase, reads start on the grid, and each read covers its segment plus
    the chain's margin on both sides."""
    spec = load_chain_text(CHAIN_GRID)
    n = int(40 * FS)
    grid = batch._segment_grid(load_chain_text(CHAIN_GRID), FS)
    assert grid == 8 * 128
    plan = plan_segments(spec, FS, n, N_CH, 10.0, grid=grid)
    margin = warmup_margin(spec, FS)
    assert len(plan) == 4 and plan[0].t_start is None and plan[-1].t_stop is None
    for a, b in zip(plan, plan[1:]):
        assert a.t_stop == b.t_start and abs(a.t_stop - 10.0 * b.index) <= grid / FS
        start = round((b.t_start - margin) * FS)
        assert start % grid == 0
        assert a.t_read_stop >= a.t_stop + margin


@pytest.mark.parametrize("text", [CHAIN_GRID, CHAIN], ids=["cbf-first", "dft_filter-first"])
def test_four_segments_equal_the_single_run(tmp_path, client, text):
    """dft_filter (overlap-save frames), cbf (frames, GEMM batches), integrate, btr, lofar and
    bearings all frame on the absolute sample grid and the reads cover whole frames and
    batches: four segments give the single run bit for bit, every dataset."""
    rec = make_recording(tmp_path / "long.h5", 24.0, 7)
    chain = tmp_path / "c.toml"
    chain.write_text(text)
    ref = single_run(rec, chain.read_text(), tmp_path / "ref.h5")
    res = batch.run_batch([rec], chain, tmp_path / "seg", client, segment_s=6.0)
    assert res[0].status == "done" and res[0].segments == 4
    assert_same(ref, tmp_path / "seg" / "long.h5")


def test_worker_killed_mid_task_and_batch_completes(tmp_path, client, chain_file):
    """A worker is SIGKILLed while it writes an output; the nanny restarts it, Dask runs the
    task again and every output is complete and equal to a clean run's."""
    d = tmp_path / "r"
    d.mkdir()
    recs = [make_recording(d / f"k{i}.h5", 12.0, 10 + i) for i in range(2)]
    out = tmp_path / "out"
    killed: list[str] = []

    def killer() -> None:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and not killed:
            if out.is_dir() and any(out.glob(".*.part")):
                busy = [w for w, ks in client.processing().items() if ks]
                if busy:
                    pids = client.run(os.getpid, workers=[busy[0]])
                    os.kill(pids[busy[0]], 9)
                    killed.append(busy[0])
                    return
            time.sleep(0.01)

    th = threading.Thread(target=killer)
    th.start()
    res = batch.run_batch(recs, chain_file, out, client, retries=2)
    th.join()
    assert killed, "no worker was killed mid-task"
    assert [r.status for r in res] == ["done", "done"], [r.error for r in res]
    clean = batch.run_batch(recs, chain_file, tmp_path / "clean", client)
    for r, c in zip(res, clean):
        assert batch.is_complete(r.output)
        assert_same(c.output, r.output)
    assert not list(out.glob(".*.part"))


def test_resume_processes_only_missing_outputs(tmp_path, client, recs, chain_file):
    """After a batch interrupted with one output missing (a stale temporary file and an
    incomplete file in its place), --resume runs that input only."""
    out = tmp_path / "out"
    first = batch.run_batch(recs[:2], chain_file, out, client)
    assert [r.status for r in first] == ["done", "done"]
    stamps = {p.name: p.stat().st_mtime_ns for p in out.glob("*.h5")}
    stale = out / f".{recs[2].stem}.h5.abc.part"
    stale.write_bytes(b"partial")
    with h5py.File(out / f"{recs[2].stem}.h5", "w") as f:
        f.attrs["complete"] = False
    res = batch.run_batch(recs, chain_file, out, client, resume=True)
    assert [r.status for r in res] == ["skipped", "skipped", "done"]
    assert {p: (out / p).stat().st_mtime_ns for p in stamps} == stamps
    assert batch.is_complete(out / f"{recs[2].stem}.h5") and not stale.exists()


def test_corrupt_input_fails_alone(tmp_path, client, recs, chain_file, capsys):
    """One corrupt input among three: two outputs, a summary naming it, exit status 1."""
    from arrayproc.app.cli import main
    bad = tmp_path / "bad.h5"
    bad.write_bytes(b"\x89HDF\r\n\x1a\n" + b"\0" * 100)
    lst = tmp_path / "inputs.txt"
    lst.write_text(f"{recs[0]}\n# a comment\nbad.h5\n")
    rc = main(["batch", str(lst), str(recs[1]), "-c", str(chain_file), "-o",
               str(tmp_path / "out"), "--scheduler", client.scheduler.address,
               "--no-progress"])
    err = capsys.readouterr().err
    assert rc == 1
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["rec0.h5", "rec1.h5"]
    assert "2 done, 0 skipped, 1 failed of 3 inputs: bad.h5 (" in err
    assert err.count("Traceback") == 0


def test_local_workers_keep_glibc_malloc_defaults(tmp_path, client):
    """Dask's nanny starts workers with MALLOC_TRIM_THRESHOLD_=65536 (the module's client here
    has it, and its nanny wrote it into this process's environment), which switches off glibc's
    dynamic mmap threshold: every array above 128 KiB is mapped fresh, page by page. The
    batch's LocalCluster workers run without it (and with the event-loop settings of
    WORKER_CONFIG), and the same task takes several times fewer minor page faults there; a
    cluster that sets it gets a note."""
    import dask
    rec = make_recording(tmp_path / "m.h5", 12.0, 3)
    text = CHAIN.replace("block = 3000", "block = 8192")  # 8192 x 8 float32: 256 KiB blocks
    client.wait_for_workers(2, timeout=120)  # a test above kills a worker; its nanny restarts it
    assert "note: 2 of 2 workers" in batch.malloc_note(client)
    ours, cluster = batch.start_client(workers=1, threads=1)
    try:
        env = ours.run(batch._malloc_env)
        assert list(env.values()) == [(None, None)]
        for key, value in batch.WORKER_CONFIG.items():  # the quieter event loop reached it
            assert list(ours.run(dask.config.get, key).values()) == [value], key
        assert batch.malloc_note(ours) is None
        faults = {}
        for name, c in (("dask", client), ("ours", ours)):
            runs = [c.submit(batch.process_task, str(rec), text, str(tmp_path / f"{name}{i}.h5"),
                             1, 0, pure=False, workers=[next(iter(c.scheduler_info()["workers"]))]
                             ).result() for i in range(3)]
            assert all(r["status"] == "done" for r in runs)
            faults[name] = min(r["minor_faults"] for r in runs[1:])  # after the first (JIT)
    finally:
        ours.close()
        cluster.close()
    assert faults["dask"] > 2.5 * faults["ours"], faults
    assert_same(tmp_path / "dask2.h5", tmp_path / "ours2.h5")


def test_inputs_globs_lists_and_seeds(tmp_path):
    for n in ("a.h5", "b.h5", "c.dat"):
        (tmp_path / n).write_bytes(b"")
    sub = tmp_path / "sub"
    sub.mkdir()
    (sub / "a.h5").write_bytes(b"")
    (tmp_path / "l.lst").write_text("c.dat\n")
    got = batch.expand_inputs([str(tmp_path / "*.h5"), str(tmp_path / "l.lst")])
    assert [p.name for p in got] == ["a.h5", "b.h5", "c.dat"]
    with pytest.raises(batch.ConfigError, match="same stem"):
        batch.expand_inputs([str(tmp_path / "a.h5"), str(sub / "a.h5")])
    with pytest.raises(batch.ConfigError, match="no file matches"):
        batch.expand_inputs([str(tmp_path / "*.wav")])
    s = batch.task_seeds(5, 3, [1, 4, 2])
    assert [len(x) for x in s] == [1, 4, 2]
    assert len({v for x in s for v in x}) == 7
    assert s == batch.task_seeds(5, 3, [1, 4, 2])
    assert s[1] == batch.task_seeds(5, 3, [3, 4, 1])[1]  # keyed by input, not by the others
    assert batch.worker_threads(2, 2) == 1 and batch.worker_threads(1, 2) == 2


def test_without_dask_says_how_to_install(monkeypatch):
    import builtins
    real = builtins.__import__

    def fake(name, *a, **k):
        if name.split(".")[0] in ("distributed", "dask"):
            raise ImportError(name)
        return real(name, *a, **k)
    monkeypatch.setattr(builtins, "__import__", fake)
    with pytest.raises(batch.ConfigError, match=r"pip install 'arrayproc\[dask\]'"):
        batch.require_dask()


def _draw_mean(n_runs: int, seed: int, scale: float = 1.0) -> np.ndarray:
    """A stand-in Monte Carlo chunk: per-run means of seeded draws."""
    return scale * np.random.default_rng(seed).standard_normal((n_runs, 16)).mean(axis=1)


def test_monte_carlo_chunks_do_not_depend_on_the_workers(client):
    """The same chunks and seeds here and on 2 workers: the same bytes."""
    from arrayproc.evaluate.distributed import chunk_seeds, spread
    assert [n for n, _ in chunk_seeds(25, 3, 10)] == [10, 10, 5]
    here = np.concatenate(spread(_draw_mean, 25, 3, None, 10, scale=2.0))
    there = np.concatenate(spread(_draw_mean, 25, 3, client, 10, scale=2.0))
    assert here.shape == (25,) and here.tobytes() == there.tobytes()
    assert not np.array_equal(here, np.concatenate(spread(_draw_mean, 25, 4, None, 10)))


@pytest.mark.slow
def test_lr_table_same_on_two_workers_as_here(client):
    """The L-R table from chunks on 2 workers equals the one computed here."""
    from arrayproc.evaluate.distributed import lr_table
    here = lr_table(40, 7, [1], ["ekf", "ukf"], chunk=10)
    there = lr_table(40, 7, [1], ["ekf", "ukf"], client=client, chunk=10)
    for f in ("ekf", "ukf"):
        for k, v in here[1][f].items():
            if not k.startswith("seconds"):
                assert np.array_equal(np.asarray(v), np.asarray(there[1][f][k]),
                                      equal_nan=True), (f, k)
