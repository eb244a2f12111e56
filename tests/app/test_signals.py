"""Signals: SIGINT, SIGTERM and SIGHUP sent at random times to ``process`` and
``simulate`` stop the run with status 128 + signal, one ``arrayproc: error:`` line, no
traceback, no output and no ``.part`` file, and a pre-existing output untouched.

A trial waits until the child has installed arrayproc's handlers (SIGTERM and SIGHUP caught in
``/proc/PID/status``: before that the interpreter is still starting and no file is open), then
sleeps a random delay (seeded) and sends the signal. The default run does one trial per signal
and command; ``-m slow`` does 20 per command.
"""

from __future__ import annotations

import hashlib
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from arrayproc.io.geometry import line_array
from arrayproc.io.recording import RecordingWriter

SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)

# A long run of small blocks: every block goes through the engine and the products writer.
CHAIN = '[input]\nblock = 32\n[[stage]]\ntype = "power"\n'

SCENARIO = """
[recording]
fs = 2048.0
duration = 3600.0
seed = 3

[array]
type = "line"
n = 8
spacing = 0.75

[[source]]
name = "s"
start = [0.0, 2000.0]
tonals = [{ freq = 300.0, level_db = 140.0 }]

[noise]
level_db = 60.0
"""


@pytest.fixture(scope="module")
def inputs(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("sig")
    x = np.random.default_rng(11).standard_normal((400_000, 4)).astype(np.float32)
    with RecordingWriter(d / "rec.h5", 1000.0, 4, positions=line_array(4, 0.5)) as w:
        w.append(x)
    (d / "chain.toml").write_text(CHAIN)
    (d / "scenario.toml").write_text(SCENARIO)
    return d


def _handlers_installed(pid: int) -> bool:
    try:
        text = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return False
    caught = int(next(line.split()[1] for line in text.splitlines()
                      if line.startswith("SigCgt:")), 16)
    return all(caught >> (s - 1) & 1 for s in (signal.SIGTERM, signal.SIGHUP))


def _digest(p: Path) -> str:
    return hashlib.sha256(p.read_bytes()).hexdigest()


def run_trial(inputs: Path, work: Path, command: str, sig: int, delay: float) -> list[str]:
    """One interrupted run; returns the problems found (empty: clean)."""
    work.mkdir()
    out = work / "out.h5"
    out.write_bytes(b"previous output, must survive\n")
    before = _digest(out)
    ins = {p: _digest(p) for p in inputs.iterdir()}
    if command == "process":
        args = ["process", str(inputs / "rec.h5"), "-c", str(inputs / "chain.toml"), "-o",
                str(out), "--no-progress"]
    else:
        args = ["simulate", str(inputs / "scenario.toml"), "-o", str(out), "--no-progress"]
    p = subprocess.Popen([sys.executable, "-m", "arrayproc", *args], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, cwd=work)
    t0 = time.monotonic()
    while not _handlers_installed(p.pid) and p.poll() is None and time.monotonic() - t0 < 120:
        time.sleep(0.01)
    time.sleep(delay)
    if p.poll() is None:
        p.send_signal(sig)
    try:
        _, err = p.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        p.kill()
        _, err = p.communicate()
        return [f"{signal.Signals(sig).name} after {delay:.2f} s: did not stop in 120 s"]
    problems = []
    lines = err.strip().splitlines()
    if p.returncode != 128 + sig:
        problems.append(f"exit {p.returncode}")
    if len(lines) != 1 or not lines[0].startswith("arrayproc: error: interrupted"):
        problems.append(f"stderr {lines[-3:]!r}")
    if "Traceback" in err:
        problems.append("traceback")
    left = sorted(x.name for x in work.iterdir() if x.name != "out.h5")
    if left:
        problems.append(f"left {left}")
    if _digest(out) != before:
        problems.append("pre-existing output changed")
    if {q: _digest(q) for q in inputs.iterdir()} != ins:
        problems.append("an input changed")
    return [f"{command} {signal.Signals(sig).name} after {delay:.2f} s: {', '.join(problems)}"
            ] if problems else []


def trials(n_per_command: int, seed: int) -> list[tuple[str, int, float]]:
    rng = np.random.default_rng(seed)
    out = []
    for command in ("process", "simulate"):
        for k in range(n_per_command):
            out.append((command, SIGNALS[k % 3], float(rng.uniform(0.0, 2.0))))
    return out


@pytest.mark.parametrize("command,sig,delay", trials(3, seed=2026),
                         ids=lambda v: getattr(v, "name", str(v)))
def test_signal_stops_cleanly(inputs, tmp_path, command, sig, delay):
    problems = run_trial(inputs, tmp_path / "w", command, sig, delay)
    assert not problems, problems


@pytest.mark.slow
def test_signals_20_trials_each(inputs, tmp_path):
    plan = trials(20, seed=13)
    problems = []
    for i, (command, sig, delay) in enumerate(plan):
        problems += run_trial(inputs, tmp_path / f"w{i}", command, sig, delay)
    print(f"signal trials: {len(plan)}, clean: {len(plan) - len(problems)}")
    assert not problems, problems


def test_a_stop_raised_where_python_cannot_propagate_it_prints_nothing():
    """A SIGTERM landing in a weakref callback or __del__ becomes an 'unraisable' exception:
    the stop is already recorded, so the hook drops it instead of printing a traceback; other
    unraisable exceptions still reach the previous hook."""
    import types

    from arrayproc.app.cli import _quiet_unraisable
    from arrayproc.errors import Interrupted
    seen = []
    hook = _quiet_unraisable(seen.append)
    stop = types.SimpleNamespace(exc_value=Interrupted(15))
    other = types.SimpleNamespace(exc_value=ValueError("x"))
    hook(stop)
    hook(other)
    assert seen == [other]
