"""A stop signal that Python wraps in another exception (a signal landing while a class body
runs ``__set_name__`` during an import becomes a RuntimeError) still stops the run as a
signal: status 128 + signal, one ``arrayproc: error:`` line, not an internal error."""

from __future__ import annotations

import argparse
import signal

from arrayproc.app.cli import _run
from arrayproc.errors import Interrupted


def _wrapped(args: argparse.Namespace) -> int:
    try:
        raise Interrupted(signal.SIGTERM)
    except Interrupted as e:
        raise RuntimeError("Error calling __set_name__ on 'Field' instance") from e


def _bug(args: argparse.Namespace) -> int:
    raise RuntimeError("a real bug")


def test_wrapped_signal_is_a_stop(capsys):
    assert _run(argparse.Namespace(func=_wrapped)) == 128 + signal.SIGTERM
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["arrayproc: error: interrupted by SIGTERM; no output written"]


def test_other_runtime_errors_stay_internal(capsys, monkeypatch):
    monkeypatch.delenv("ARRAYPROC_DEBUG", raising=False)
    assert _run(argparse.Namespace(func=_bug)) == 70
    assert "internal error: RuntimeError: a real bug" in capsys.readouterr().err
