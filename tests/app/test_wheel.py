"""The package as a user installs it: the wheel carries its data (chains, scenarios, trackers,
TL tables), and the installed demo runs from a directory outside the repository."""

from __future__ import annotations

import os
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from arrayproc.data import data_path

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("wheel")
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps",
                    "-q", "-w", str(out), str(REPO)], check=True, capture_output=True)
    return next(out.glob("arrayproc-*.whl"))


def test_wheel_carries_the_package_data(wheel):
    names = set(zipfile.ZipFile(wheel).namelist())
    for folder in ("chains", "scenarios", "trackers", "tl"):
        shipped = sorted(p.name for p in data_path(folder).iterdir()
                         if p.suffix in (".toml", ".h5", ".json"))
        assert shipped, folder
        for name in shipped:
            assert f"arrayproc/data/{folder}/{name}" in names, (folder, name)


@pytest.mark.slow
def test_installed_demo_runs_outside_the_repository(wheel, tmp_path):
    site = tmp_path / "site"
    subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "-q", "--target",
                    str(site), str(wheel)], check=True, capture_output=True)
    work = tmp_path / "elsewhere"
    work.mkdir()
    env = dict(os.environ, PYTHONPATH=str(site), ARRAYPROC_XAV="")
    code = ("import arrayproc, sys; assert arrayproc.__file__.startswith(sys.argv[1]), "
            "arrayproc.__file__; from arrayproc.app.cli import main; "
            "sys.exit(main(['demo', '-o', 'out', '--no-progress']))")
    r = subprocess.run([sys.executable, "-c", code, str(site)], cwd=work, env=env,
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-2000:]
    pngs = sorted(p.name for p in (work / "out").glob("*.png"))
    assert {"btr.png", "lofar.png", "track.png"} <= set(pngs), pngs
