"""Every way into arrayproc, driven through the real command line (``main``).

Each case of :mod:`tests.app.hostile_cases` must give exit status 2, exactly one stderr line
``arrayproc: error: …`` containing the case's key text, no traceback, no new file (no output,
no ``.part``), and every input file byte-identical (symlinks still pointing where they did).
"""

from __future__ import annotations

import hashlib
import os
import shutil
import stat
from pathlib import Path

import pytest

from arrayproc.app.cli import main
from tests.app.hostile_cases import CASES, close_open_writers, make_base


@pytest.fixture(scope="module")
def base(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("base")
    make_base(d)
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


def run_case(c, base: Path, tmp_path: Path, capsys) -> tuple[bool, str]:
    d = tmp_path / "w"
    shutil.copytree(base, d, symlinks=True)
    os.chdir(d)
    try:
        args = c.setup(d)
        before = snapshot(d)
        dev_null = os.stat("/dev/null")
        capsys.readouterr()
        try:
            rc = main(args)
        except SystemExit as e:  # usage errors from argparse
            rc = e.code
        err = capsys.readouterr().err
    finally:
        close_open_writers()
    lines = err.strip().splitlines()
    problems = []
    if rc != c.status:
        problems.append(f"exit {rc}")
    if len(lines) != 1 or not lines[0].startswith("arrayproc: error:"):
        problems.append(f"stderr {lines!r}")
    elif c.match and c.match.lower() not in lines[0].lower():
        problems.append(f"message lacks {c.match!r}: {lines[0]!r}")
    if "Traceback" in err:
        problems.append("traceback")
    after = snapshot(d)
    if after != before:
        new = sorted(set(after) - set(before))
        changed = sorted(k for k in before if after.get(k) != before[k])
        problems.append(f"files new {new} changed {changed}")
    st = os.stat("/dev/null")
    if not stat.S_ISCHR(st.st_mode) or st.st_rdev != dev_null.st_rdev:
        problems.append("/dev/null replaced")
    return not problems, "; ".join(problems) + (f" [{lines[0] if lines else ''}]")


@pytest.mark.parametrize("c", CASES, ids=[c.id for c in CASES])
def test_hostile_case(c, base, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    ok, why = run_case(c, base, tmp_path, capsys)
    assert ok, f"{c.cls}: {c.id}: {why}"


def test_at_least_80_cases_over_every_class():
    classes = {c.cls for c in CASES}
    assert len(CASES) >= 80
    assert len(classes) >= 12
    assert len({c.id for c in CASES}) == len(CASES)
