"""The demonstration of a disk filling during a batch: four recordings processed by
``arrayproc batch`` into a tmpfs that holds two and a half outputs. The two outputs written
before the disk filled are complete and stay byte-identical; the summary names the two that
could not be written, and nothing else is left in the folder; after the space is freed
(the tmpfs grown), ``batch --resume`` skips the two and completes the others, equal to what
``arrayproc process`` writes. The measured transcript is in docs/reliability.md.
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from arrayproc.io.geometry import line_array
from arrayproc.io.recording import RecordingWriter
from tests.faults.cases import CHAIN_BIG, can_mount

REPO = Path(__file__).resolve().parents[2]
pytest.importorskip("distributed")


def _run(args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(REPO))
    return subprocess.run([sys.executable, "-m", "arrayproc", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=600)


def _sha(p: Path) -> str:
    return hashlib.sha256(p.read_bytes()).hexdigest()


@pytest.mark.slow
@pytest.mark.skipif(not can_mount(), reason="mounting a tmpfs is not allowed here")
def test_batch_with_the_disk_filling_then_resume(tmp_path):
    for i in range(4):
        x = np.random.default_rng(i).standard_normal((40000, 8)).astype(np.float32)
        with RecordingWriter(tmp_path / f"rec{i}.h5", 1000.0, 8,
                             positions=line_array(8, 0.75)) as w:
            w.append(x)
    (tmp_path / "chain.toml").write_text(CHAIN_BIG)
    inputs = {p.name: _sha(p) for p in tmp_path.glob("rec*.h5")}
    out = tmp_path / "out"
    out.mkdir()
    # each output takes 16 kB (4 pages): room for two and a half
    subprocess.run(["mount", "-t", "tmpfs", "-o", "size=40k", "tmpfs", str(out)], check=True)
    try:
        args = ["batch", *sorted(inputs), "-c", "chain.toml", "-o", "out", "--workers", "1",
                "--no-progress"]
        r = _run(args, tmp_path)
        assert r.returncode == 1, r.stderr
        assert "Traceback" not in r.stderr
        summary = [x for x in r.stderr.splitlines() if "done," in x]
        assert len(summary) == 1, r.stderr
        line = summary[0]
        assert line.startswith("arrayproc batch: 2 done, 0 skipped, 2 failed of 4 inputs")
        assert "rec2.h5 (out/rec2.h5: cannot write the output: No space left" in line
        assert "rec3.h5 (out/rec3.h5: cannot write the output: No space left" in line
        assert "--resume" in line
        assert sorted(os.listdir(out)) == ["rec0.h5", "rec1.h5"]  # no .part
        first = {n: _sha(out / n) for n in ("rec0.h5", "rec1.h5")}
        for n in first:
            with h5py.File(out / n) as f:
                assert f.attrs["complete"]
        subprocess.run(["mount", "-o", "remount,size=200k", str(out)], check=True)
        r2 = _run(args + ["--resume"], tmp_path)
        assert r2.returncode == 0, r2.stderr
        assert "2 done, 2 skipped, 0 failed of 4 inputs" in r2.stdout + r2.stderr
        assert sorted(os.listdir(out)) == [f"rec{i}.h5" for i in range(4)]
        assert {n: _sha(out / n) for n in first} == first  # untouched by the resume
        ref = _run(["process", "rec2.h5", "-c", "chain.toml", "-o", "p2.h5", "-q"], tmp_path)
        assert ref.returncode == 0, ref.stderr
        with h5py.File(out / "rec2.h5") as a, h5py.File(tmp_path / "p2.h5") as b:
            assert a.attrs["complete"]
            np.testing.assert_array_equal(a["btr/power_db"][()], b["btr/power_db"][()])
    finally:
        subprocess.run(["umount", "-l", str(out)], capture_output=True)
    assert {p.name: _sha(p) for p in tmp_path.glob("rec*.h5")} == inputs
