"""The command line's flags, by walking the argparse parser: every argument has help text,
every command has ``-q`` with one meaning, and a short flag means the same on every command
(``-c`` the configuration, ``-o`` the output, ``-q`` quiet)."""

from __future__ import annotations

import argparse

import pytest

from arrayproc.app.cli import build_parser
from arrayproc.app.options import QUIET_HELP


def _commands() -> dict[str, argparse.ArgumentParser]:
    p = build_parser()
    sub = next(a for a in p._actions if isinstance(a, argparse._SubParsersAction))
    return dict(sub.choices)


def _arguments(p: argparse.ArgumentParser) -> list[argparse.Action]:
    return [a for a in p._actions if not isinstance(a, argparse._HelpAction)]


COMMANDS = sorted(_commands())


def test_the_walk_sees_every_command():
    assert {"info", "process", "import", "simulate", "plot", "track", "tma", "export",
            "batch", "demo", "data-dir"} <= set(COMMANDS)


@pytest.mark.parametrize("name", COMMANDS)
def test_every_argument_has_help(name):
    missing = [a.option_strings or [a.dest] for a in _arguments(_commands()[name])
               if not a.help or a.help == argparse.SUPPRESS or not a.help.strip()]
    assert missing == []


def test_top_level_options_have_help():
    assert all(a.help and a.help != argparse.SUPPRESS for a in build_parser()._actions
               if a.option_strings)


@pytest.mark.parametrize("name", COMMANDS)
def test_every_command_has_quiet_with_one_meaning(name):
    q = [a for a in _arguments(_commands()[name]) if "-q" in a.option_strings]
    assert len(q) == 1
    assert q[0].option_strings == ["-q", "--quiet"] and q[0].dest == "quiet"
    assert q[0].help == QUIET_HELP and q[0].nargs == 0 and q[0].default is False


def test_one_meaning_per_short_flag():
    meanings: dict[str, set[tuple[str, str]]] = {}
    for p in _commands().values():
        for a in _arguments(p):
            longs = [s for s in a.option_strings if s.startswith("--")]
            for s in a.option_strings:
                if len(s) == 2 and s[0] == "-" and s[1] != "-":
                    meanings.setdefault(s, set()).add((a.dest, longs[0] if longs else ""))
    assert {s: len(m) for s, m in meanings.items()} == {s: 1 for s in meanings}
    assert meanings["-c"] == {("config", "--config")}
    assert meanings["-o"] == {("output", "--output")}
    assert meanings["-q"] == {("quiet", "--quiet")}


def test_chain_is_an_alias_of_config_where_a_chain_is_meant():
    p = build_parser()
    a = p.parse_args(["process", "rec.h5", "--chain", "c.toml", "-o", "p.h5"])
    b = p.parse_args(["process", "rec.h5", "-c", "c.toml", "-o", "p.h5"])
    c = p.parse_args(["batch", "rec.h5", "--config", "c.toml", "-o", "out"])
    assert a.config == b.config == c.config == "c.toml"


def test_quiet_prints_nothing_on_stdout(capsys):
    from arrayproc.app.cli import main
    assert main(["data-dir", "-q"]) == 0
    assert capsys.readouterr().out == ""
    assert main(["data-dir"]) == 0
    assert capsys.readouterr().out.strip() != ""


def test_info_quiet_checks_the_file(tmp_path, rng, capsys):
    import numpy as np

    from arrayproc.app.cli import main
    from arrayproc.io.geometry import line_array
    from tests.conftest import write_recording
    rec = write_recording(tmp_path / "r.h5", rng.standard_normal((64, 2)).astype(np.float32),
                          positions=line_array(2, 0.5))
    assert main(["info", str(rec), "-q"]) == 0
    assert capsys.readouterr().out == ""
    (tmp_path / "bad.h5").write_bytes(b"not hdf5")
    assert main(["info", str(tmp_path / "bad.h5"), "-q"]) == 2
    out = capsys.readouterr()
    assert out.out == "" and out.err.startswith("arrayproc: error:")
