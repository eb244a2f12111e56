"""The fault table through the real command line (a subprocess per case): faults of the
environment (disk full on a tmpfs, injected write failures, a read-only file system, the
memory limit) and damaged inputs (truncations, bit flips in the superblock and in chunk
data, a dataset shorter than it declares, files open by a writer), then SIGKILL at seeded
random times in ``process``, ``simulate`` and ``batch``.

Every case: the exit status documented for its class (never one from a signal), exactly
one ``arrayproc: error:`` line on stderr with the case's key text, no traceback, nothing
new left behind (no output, no ``.part``), every input byte-identical. The default run takes
the cases marked ``default`` and one kill per command; ``-m slow`` runs the whole table and
five kills per command.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from tests.faults.cases import CASES, can_mount, kill_writers, make_fault_base, unmount_all

REPO = Path(__file__).resolve().parents[2]
#: The package the subprocesses import (default: this checkout); pointing it at another
#: checkout measures that code on the same table (the "before" counts of docs/reliability.md).
CODE = os.environ.get("ARRAYPROC_FAULTS_CODE", str(REPO))
MOUNTING = can_mount()
NEEDS_MOUNT = ("disk full (tmpfs)", "read-only file system")


@pytest.fixture(scope="module")
def base(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("faultbase")
    make_fault_base(d)
    return d


def snapshot(d: Path) -> dict[str, tuple]:
    """Every entry below d: (kind, content hash or link target)."""
    out = {}
    for root, dirs, files in os.walk(d):
        for name in dirs + files:
            p = Path(root) / name
            st = os.lstat(p)
            if stat.S_ISLNK(st.st_mode):
                out[str(p)] = ("link", os.readlink(p))
            elif stat.S_ISREG(st.st_mode):
                out[str(p)] = ("file", hashlib.sha256(p.read_bytes()).hexdigest())
            else:
                out[str(p)] = ("other", stat.S_IFMT(st.st_mode))
    return out


def command(args: list[str], env: dict[str, str] | None = None, rlimit_as: int | None = None,
            **kw) -> subprocess.Popen:
    """``python -m arrayproc ARGS`` with this worktree's package."""
    e = dict(os.environ, PYTHONPATH=CODE, **(env or {}))
    e.pop("ARRAYPROC_DEBUG", None)

    def limit() -> None:
        if rlimit_as is not None:
            import resource
            resource.setrlimit(resource.RLIMIT_AS, (rlimit_as, rlimit_as))
    return subprocess.Popen([sys.executable, "-m", "arrayproc", *args], env=e,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=limit if rlimit_as else None, **kw)


def problems_of(rc: int, err: str, status: int, match: str) -> list[str]:
    lines = err.strip().splitlines()
    found = []
    if rc < 0:
        found.append(f"killed by signal {-rc}")
    elif rc != status:
        found.append(f"exit {rc}, expected {status}")
    if "Traceback" in err or "Segmentation" in err:
        found.append("traceback")
    if len(lines) != 1 or not lines[0].startswith("arrayproc: error:"):
        found.append(f"stderr {lines!r}")
    elif match.lower() not in lines[0].lower():
        found.append(f"message lacks {match!r}")
    return found


def run_case(c, base: Path, tmp_path: Path) -> tuple[list[str], str]:
    d = tmp_path / "w"
    shutil.copytree(base, d)
    try:
        args = c.setup(d)
        before = snapshot(d)
        p = command(args, c.env, c.rlimit_as, cwd=d)
        try:
            _, err = p.communicate(timeout=300)
        finally:
            if p.poll() is None:
                p.kill()
                p.wait()
        kill_writers()
        problems = problems_of(p.returncode, err, c.status, c.match)
        after = snapshot(d)
    finally:
        kill_writers()
        unmount_all()
    if after != before:
        new = sorted(set(after) - set(before))
        changed = sorted(k for k in before if after.get(k) != before[k])
        problems.append(f"files new {new} changed {changed}")
    line = err.strip().splitlines()[0] if err.strip() else ""
    return problems, line


def _params(full: bool):
    return [pytest.param(c, id=c.id, marks=() if c.default or full else pytest.mark.slow)
            for c in CASES]


@pytest.mark.parametrize("c", _params(False))
def test_fault_case(c, base, tmp_path):
    if c.cls in NEEDS_MOUNT and not MOUNTING:
        pytest.skip("mounting a tmpfs is not allowed here (the injected cases cover ENOSPC)")
    problems, line = run_case(c, base, tmp_path)
    assert not problems, f"{c.cls}/{c.id}: {'; '.join(problems)} [{line}]"


# -- SIGKILL at random times ------------------------------------------------------------------
def _kill_args(d: Path, what: str) -> list[str]:
    if what == "process":
        return ["process", str(d / "kill.h5"), "-c", str(d / "big.toml"), "-o",
                str(d / "out.h5"), "--no-progress", "-q"]
    if what == "simulate":
        return ["simulate", str(d / "kill_scenario.toml"), "-o", str(d / "out.h5"),
                "--no-progress", "-q"]
    recs = [str(d / f"r{i}.h5") for i in range(3)]
    return ["batch", *recs, "-c", str(d / "big.toml"), "-o", str(d / "out"), "--workers", "1",
            "--no-progress", "-q"]


def _writing(work: Path, what: str) -> bool:
    """Whether the run has started writing (a temporary ``.part`` file exists)."""
    where = work / "out" if what == "batch" else work
    return where.is_dir() and any(where.glob(".*.part"))


def _complete(p: Path, what: str) -> bool:
    try:
        with h5py.File(p, "r") as f:
            return bool(f.attrs.get("complete", False)) if what != "simulate" else \
                "time_data" in f and "truth" in f
    except OSError:
        return False


def kill_trial(base: Path, work: Path, what: str, delay: float) -> tuple[list[str], str]:
    """SIGKILL ``what`` ``delay`` s after it started writing (its whole process group: the
    machine dying), then run it again (``batch --resume``): at most a ``.part`` after the
    kill, none after the second run, complete outputs, inputs unchanged."""
    shutil.copytree(base, work)
    if what == "batch":
        for i in range(3):
            shutil.copy(work / "kill.h5", work / f"r{i}.h5")
    args = _kill_args(work, what)
    before = snapshot(work)
    p = command(args, cwd=work, start_new_session=True)
    t0 = time.monotonic()
    while not _writing(work, what) and p.poll() is None and time.monotonic() - t0 < 120:
        time.sleep(0.002)
    time.sleep(delay)
    try:
        os.killpg(p.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    p.communicate()
    problems = []
    outs = [work / "out.h5"] if what != "batch" else [work / "out" / f"r{i}.h5"
                                                       for i in range(3)]
    left = set(snapshot(work)) - set(before)
    outcome = ("part left" if any(".part" in Path(k).name for k in left) else
               "output complete" if any(Path(k) in outs for k in left) else "nothing written")
    for k in sorted(left):
        name = Path(k).name
        if Path(k) in outs:
            if not _complete(Path(k), what):
                problems.append(f"after the kill {name} exists but is not complete")
        elif not (name.startswith(".") and ".part" in name) and Path(k) != work / "out":
            problems.append(f"after the kill: {name} left")
    again = command(args + (["--resume"] if what == "batch" else []), cwd=work)
    _, err = again.communicate(timeout=300)
    if again.returncode != 0:
        problems.append(f"second run exit {again.returncode}: {err.strip()[-300:]}")
    after = snapshot(work)
    parts = [k for k in after if ".part" in Path(k).name]
    if parts:
        problems.append(f".part left after the second run: {parts}")
    for o in outs:
        if not _complete(o, what):
            problems.append(f"{o.name} not complete after the second run")
    changed = [k for k in before if after.get(k) != before[k]]
    if changed:
        problems.append(f"inputs changed: {changed}")
    return problems, outcome


#: Kill delays are drawn in [0, this) s after the first ``.part`` file appears: a kill while
#: writing, or (the longer ones) after the output was committed.
KILLS = {"process": 1.0, "simulate": 1.0, "batch": 4.0}


def _one_kill(what: str, base: Path, tmp_path: Path) -> None:
    delay = float(np.random.default_rng(sum(map(ord, what))).uniform(0, KILLS[what]))
    problems, outcome = kill_trial(base, tmp_path / "w", what, delay)
    assert not problems, f"{what} killed at {delay:.2f} s ({outcome}): {problems}"


def test_sigkill_process_then_rerun(base, tmp_path):
    _one_kill("process", base, tmp_path)


@pytest.mark.slow
@pytest.mark.parametrize("what", ["simulate", "batch"])
def test_sigkill_then_rerun(what, base, tmp_path):
    _one_kill(what, base, tmp_path)


@pytest.mark.slow
@pytest.mark.parametrize("what", ["process", "simulate", "batch"])
def test_sigkill_many(what, base, tmp_path):
    rng = np.random.default_rng(2026 + len(what))
    bad, outcomes = [], []
    for k in range(5):
        delay = float(rng.uniform(0, KILLS[what]))
        problems, outcome = kill_trial(base, tmp_path / f"w{k}", what, delay)
        outcomes.append(f"{delay:.2f} s: {outcome}")
        if problems:
            bad.append(f"{delay:.2f} s: {problems}")
    print(f"SIGKILL {what}: {outcomes}")
    assert not bad, f"{what}: {bad}"


# -- a stop signal during start-up --------------------------------------------------------------
def _caught(pid: int) -> bool:
    try:
        text = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return False
    mask = int(next(x.split()[1] for x in text.splitlines() if x.startswith("SigCgt:")), 16)
    return bool(mask >> (signal.SIGTERM - 1) & 1)


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM, signal.SIGHUP])
def test_signal_in_the_first_tenth_of_a_second(sig, base, tmp_path):
    """A signal 0-0.1 s after arrayproc's first line ran (``app/early.py``; the imports of
    numpy, h5py and the stages follow) stops like one later: 128 + N, one line, nothing
    left. Before arrayproc's first line is the interpreter's own start-up (docs/reliability.md)."""
    d = tmp_path / "w"
    shutil.copytree(base, d)
    before = snapshot(d)
    rng = np.random.default_rng(int(sig))
    delays = []
    for _ in range(2):
        p = command(["process", str(d / "long.h5"), "-c", str(d / "big.toml"), "-o",
                     str(d / "out.h5"), "--no-progress", "-q"])
        t0 = time.monotonic()
        while not _caught(p.pid) and p.poll() is None and time.monotonic() - t0 < 30:
            time.sleep(0.0005)
        delay = float(rng.uniform(0, 0.1))
        delays.append(delay)
        time.sleep(delay)
        p.send_signal(sig)
        _, err = p.communicate(timeout=120)
        problems = problems_of(p.returncode, err, 128 + int(sig), "interrupted by")
        assert not problems, f"signal {int(sig)} at +{delay:.3f} s: {problems}"
        assert snapshot(d) == before
