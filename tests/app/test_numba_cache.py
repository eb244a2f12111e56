"""With numba's cache directories unwritable (package installed by root, run by a user
whose HOME is read-only) commands fall back to a private cache directory with one warning."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

from arrayproc.app.cli import ensure_numba_cache
from tests.app.hostile_cases import SCENARIO


def test_unwritable_numba_cache_dir_is_replaced_with_one_warning(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    (ro / "file").write_text("not a directory")
    env = {"NUMBA_CACHE_DIR": str(ro / "file" / "cache")}  # cannot be created
    warned = []
    d = ensure_numba_cache(warned.append, env)
    assert d is not None and env["NUMBA_CACHE_DIR"] == d and os.access(d, os.W_OK)
    assert len(warned) == 1 and "not writable" in warned[0]


def test_writable_numba_cache_dir_is_kept(tmp_path):
    env = {"NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    warned = []
    assert ensure_numba_cache(warned.append, env) is None
    assert env["NUMBA_CACHE_DIR"] == str(tmp_path / "cache") and not warned


@pytest.mark.skipif(os.geteuid() != 0 or shutil.which("setpriv") is None,
                    reason="needs root to run a command as another user")
def test_simulate_as_user_with_read_only_home():
    """`simulate` (numba kernels with cache=True) as user nobody, HOME unwritable: it runs,
    with one `arrayproc: warning: numba cache` line."""
    import arrayproc
    pkg = Path(arrayproc.__file__).parent
    if os.stat(pkg).st_uid != 0 or os.stat(pkg).st_mode & 0o002:
        pytest.skip("package directory is writable by others")
    probe = subprocess.run(["setpriv", "--reuid=65534", "--regid=65534", "--clear-groups",
                            sys.executable, "-c", "pass"], capture_output=True, text=True)
    if probe.returncode != 0:  # e.g. an interpreter whose libpython lies under a private /root
        pytest.skip(f"this interpreter cannot run as user nobody: {probe.stderr.strip()[:200]}")
    d = Path(tempfile.mkdtemp(prefix="arrayproc-nobody-"))
    try:
        os.chmod(d, 0o777)
        (d / "s.toml").write_text(SCENARIO)
        os.chmod(d / "s.toml", 0o644)
        env = {k: v for k, v in os.environ.items() if not k.startswith(("NUMBA_", "XDG_"))}
        env["HOME"] = "/nonexistent"
        r = subprocess.run(["setpriv", "--reuid=65534", "--regid=65534", "--clear-groups",
                            sys.executable, "-m", "arrayproc", "simulate", str(d / "s.toml"),
                            "-o", str(d / "out.h5"), "--no-progress", "-q"],
                           capture_output=True, text=True, env=env, cwd=d, timeout=600)
        lines = r.stderr.strip().splitlines()
        assert r.returncode == 0, r.stderr[-2000:]
        assert (d / "out.h5").exists()
        assert len(lines) == 1 and lines[0].startswith("arrayproc: warning: numba cache:"), lines
    finally:
        shutil.rmtree(d, ignore_errors=True)
