"""The package logs through :mod:`logging` and writes nothing to stdout or stderr itself
outside the application layer; the CLI shows the records at the level ``-q`` / ``-v`` set."""

from __future__ import annotations

import ast
import logging
from pathlib import Path

import numpy as np
import pytest

from arrayproc.app import logs
from arrayproc.app.cli import main
from arrayproc.app.options import VERBOSE_HELP
from tests.app.test_cli_flags import COMMANDS, _arguments, _commands

PACKAGE = Path(__file__).resolve().parents[2] / "arrayproc"


def _writes(path: Path) -> list[str]:
    """``print(...)`` calls and ``sys.stdout`` / ``sys.stderr`` uses in a module."""
    found = []
    where = path.relative_to(PACKAGE.parent) if path.is_relative_to(PACKAGE) else path.name
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) \
                and node.func.id == "print":
            found.append(f"{where}:{node.lineno}: print")
        if isinstance(node, ast.Attribute) and node.attr in ("stdout", "stderr") \
                and isinstance(node.value, ast.Name) and node.value.id == "sys":
            found.append(f"{where}:{node.lineno}: sys.{node.attr}")
    return found


def test_library_code_writes_through_logging_only():
    found = [w for p in sorted(PACKAGE.rglob("*.py")) if "app" not in p.relative_to(
        PACKAGE).parts for w in _writes(p)]
    assert found == []


def test_the_scan_sees_a_print(tmp_path):
    p = tmp_path / "m.py"
    p.write_text("import sys\nprint(1)\nsys.stderr.write('x')\n")
    assert _writes(p) == ["m.py:2: print", "m.py:3: sys.stderr"]


@pytest.mark.parametrize("name", COMMANDS)
def test_every_command_has_verbose(name):
    v = [a for a in _arguments(_commands()[name]) if "-v" in a.option_strings]
    assert len(v) == 1 and v[0].option_strings == ["-v", "--verbose"]
    assert v[0].dest == "verbose" and v[0].help == VERBOSE_HELP and v[0].default == 0


def test_levels_and_lines(capsys):
    log = logging.getLogger("arrayproc.test")
    for level, shown in ((logs.level_of(quiet=True), ["warning"]),
                         (logs.level_of(), ["info", "warning"]),
                         (logs.level_of(verbose=1), ["debug", "info", "warning"])):
        restore = logs.configure(level)
        try:
            log.debug("d  detail")
            log.info("i\ninfo")
            log.warning("w")
        finally:
            restore()
        err = capsys.readouterr().err.splitlines()
        want = {"debug": "arrayproc: debug: d detail", "info": "arrayproc: i info",
                "warning": "arrayproc: warning: w"}
        assert err == [want[k] for k in shown]
    assert logging.getLogger("arrayproc").handlers == []  # restored


def test_cli_verbose_shows_debug_records_and_default_does_not(tmp_path, capsys):
    from arrayproc.io.products import ProductsWriter
    pytest.importorskip("xarray")
    p = tmp_path / "p.h5"
    with ProductsWriter(p) as w:
        w.group("power", "power").append(time=np.arange(2.0), power_db=np.zeros((2, 3)))
    assert main(["export", str(p), "--to", "netcdf", "-o", str(tmp_path / "a.nc"), "-q"]) == 0
    assert capsys.readouterr().err == ""
    assert main(["export", str(p), "--to", "netcdf", "-o", str(tmp_path / "b.nc"), "-v"]) == 0
    out = capsys.readouterr()
    assert "arrayproc: debug: netcdf: group power (power)" in out.err
    assert out.out.startswith("arrayproc: wrote")  # the summary line stays on stdout
