"""The ``arrayproc`` command line: the parser, and errors as one line.

The commands themselves are library functions (:mod:`arrayproc.app.commands`); this module
only builds the parser from the command modules listed in :data:`COMMAND_MODULES` (each has
``add_parser(sub)``, which adds its sub-commands with ``set_defaults(func=...)``), runs the
chosen one and turns what can go wrong into one line on stderr:

* a user error (:class:`~arrayproc.errors.ArrayprocError`): ``arrayproc: error: …``, status 2;
* SIGINT, SIGTERM, SIGHUP: the run stops, temporary files are removed, status 130, 143, 129;
* Python warnings (e.g. a diverging track): ``arrayproc: warning: …``; the package's log
  records (Python logging) one per line on stderr at the level ``-q`` / ``-v`` set
  (:mod:`arrayproc.app.logs`);
* a long command's end: ``arrayproc: wrote OUT (…) in T s, Nx real time, peak M MB`` on
  stdout, unless ``-q`` (:mod:`arrayproc.app.progress`);
* anything else is a bug: ``arrayproc: internal error: …``, status 70, with the traceback
  only when ``ARRAYPROC_DEBUG=1``.

Outputs are written to a temporary file and renamed, so a failed run leaves nothing behind.
"""

from __future__ import annotations

from arrayproc.app import early as _early

if _early.as_command():  # the `arrayproc` script: stop signals recorded from here on
    _early.install()

import argparse
import importlib
import os
import signal
import sys
import time
import warnings
from collections.abc import Sequence
from pathlib import Path

from arrayproc.errors import EXIT_MEMORY, EXIT_WRITE, ArrayprocError, Interrupted

#: Modules that add sub-commands: each defines ``add_parser(sub)``. A new command module
#: (e.g. ``arrayproc.app.tma``) adds its name here.
COMMAND_MODULES: tuple[str, ...] = ("arrayproc.app.commands", "arrayproc.app.batch",
                                     "arrayproc.app.demo", "arrayproc.app.catalogue",
                                     "arrayproc.app.listen", "arrayproc.app.report")

#: Signals that stop a run: exit status 128 + signal number.
STOP_SIGNALS = tuple(getattr(signal, n) for n in ("SIGINT", "SIGTERM", "SIGHUP")
                     if hasattr(signal, n))

EX_SOFTWARE = 70  # sysexits.h: internal software error

#: The exit statuses, as ``arrayproc --help`` lists them (docs/reliability.md).
EXIT_STATUSES = f"""exit status:
  0    done
  1    batch: some inputs failed (the summary names them; --resume runs them again)
  2    bad input, configuration or argument, or a damaged input file (one line names it)
  {EX_SOFTWARE}   internal error (a bug; ARRAYPROC_DEBUG=1 shows the traceback)
  {EXIT_WRITE}   an output could not be written: disk full, quota, I/O error, read-only
       file system (nothing was left behind)
  {EXIT_MEMORY}   the run reached its memory limit (--max-memory, ARRAYPROC_MAX_MEMORY or
       the process's limit); the line names the stage
  128+N  stopped by signal N: 130 SIGINT, 143 SIGTERM, 129 SIGHUP (no output written)"""


def warn(msg: str) -> None:
    """Print one warning line on stderr."""
    print(f"arrayproc: warning: {msg}", file=sys.stderr)


class _Parser(argparse.ArgumentParser):
    """Usage errors as one line, exit status 2."""

    def error(self, message: str) -> None:  # type: ignore[override]
        sub = self.prog.split(" ", 1)[1] + ": " if " " in self.prog else ""
        print(f"arrayproc: error: {sub}{message} (see {self.prog} --help)", file=sys.stderr)
        raise SystemExit(2)


def _version() -> str:
    from arrayproc import __version__
    return f"arrayproc {__version__}"


class _Version(argparse.Action):
    """``--version`` without importing more than the package's metadata."""

    def __init__(self, option_strings: Sequence[str], dest: str = argparse.SUPPRESS,
                 **kw: object) -> None:
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS,
                         help="print the version and exit")

    def __call__(self, parser, namespace, values, option_string=None) -> None:
        print(_version())
        parser.exit()


def build_parser() -> argparse.ArgumentParser:
    """The ``arrayproc`` parser with the sub-commands of every :data:`COMMAND_MODULES`."""
    p = _Parser(prog="arrayproc", description=__doc__.splitlines()[0], epilog=EXIT_STATUSES,
                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--version", action=_Version)
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    for name in COMMAND_MODULES:
        importlib.import_module(name).add_parser(sub)
    return p


# -- numba cache --------------------------------------------------------------------------------
def _dir_writable(d: Path) -> bool:
    """Whether files can be created in ``d`` (created if missing)."""
    try:
        d.mkdir(parents=True, exist_ok=True)
    except OSError:
        return False
    return os.access(d, os.W_OK | os.X_OK)


def _in_tree_cache_writable(pkg: Path) -> bool:
    """Whether numba can write its cache beside every module of the package (``__pycache__``)."""
    for d in (pkg, *(p for p in pkg.rglob("*") if p.is_dir() and p.name != "__pycache__")):
        cache = d / "__pycache__"
        target = cache if cache.exists() else d
        if not os.access(target, os.W_OK | os.X_OK):
            return False
    return True


def ensure_numba_cache(warn_fn=warn, environ: dict | None = None) -> str | None:
    """Give numba a writable cache directory when neither its in-tree cache (beside the
    installed package) nor its user-wide one (``$XDG_CACHE_HOME``/``~/.cache``) can be written,
    e.g. a package installed by root run by a user whose HOME is read-only: set
    ``NUMBA_CACHE_DIR`` to a private temporary directory, with one warning.

    Must run before numba is imported. Returns the directory set, else None.
    """
    env = os.environ if environ is None else environ
    given = env.get("NUMBA_CACHE_DIR")
    if given:
        if _dir_writable(Path(given)):
            return None
        reason = f"NUMBA_CACHE_DIR={given} is not writable"
    else:
        import arrayproc
        if _in_tree_cache_writable(Path(arrayproc.__file__).parent):
            return None
        xdg = env.get("XDG_CACHE_HOME") or os.path.join(env.get("HOME", "~"), ".cache")
        if _dir_writable(Path(os.path.expanduser(xdg)) / "numba"):
            return None
        reason = "neither the package directory nor the user cache directory is writable"
    import tempfile
    d = Path(tempfile.gettempdir()) / f"arrayproc-numba-{os.getuid()}"
    try:
        d.mkdir(mode=0o700, exist_ok=True)
        usable = d.is_dir() and not d.is_symlink() and d.stat().st_uid == os.getuid() \
            and os.access(d, os.W_OK)
    except OSError:
        usable = False
    if not usable:
        d = Path(tempfile.mkdtemp(prefix="arrayproc-numba-"))
    env["NUMBA_CACHE_DIR"] = str(d)
    warn_fn(f"numba cache: {reason}; compiled kernels are cached in {d}")
    return str(d)


# -- signals and warnings -----------------------------------------------------------------------
def _on_signal(signum: int, frame: object) -> None:
    from arrayproc.io.atomic import (
        graceful,
        in_file_driver,
        request_stop,
        set_graceful,
        stop_requested,
    )
    first = stop_requested() is None
    request_stop(signum)
    if in_file_driver(frame):  # inside HDF5's write callback: the writer's next check stops
        return
    if graceful():  # process --follow: the first signal ends the stream, a second stops now
        if first:
            return
        set_graceful(False)
        raise Interrupted(signum)
    if first:  # later signals do not interrupt the clean-up of the first
        raise Interrupted(signum)


def _install_handlers() -> dict[int, object]:
    old: dict[int, object] = {}
    for s in STOP_SIGNALS:
        try:
            old[s] = signal.signal(s, _on_signal)
        except (ValueError, OSError):  # not the main thread
            pass
    return old


def _quiet_unraisable(hook):
    """An unraisable-exception hook that drops a stop signal raised where Python cannot
    propagate it (a weakref callback, a ``__del__``): the stop is already recorded and every
    writer checks it, so printing its traceback would only break the one-line rule."""
    def quiet(u) -> None:
        if isinstance(u.exc_value, KeyboardInterrupt) or _stop_cause(u.exc_value) is not None:
            return  # also a C callback's SystemError raised from the stop (h5py's file driver)
        hook(u)
    return quiet


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    if issubclass(category, (DeprecationWarning, PendingDeprecationWarning)) and \
            _PACKAGE_DIR not in os.path.abspath(filename):
        return  # another library's notice to its own callers, not to the user of the CLI
    text = " ".join(str(message).split())
    print(f"arrayproc: warning: {text}", file=sys.stderr)


_PACKAGE_DIR = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _stop_cause(e: BaseException) -> Interrupted | None:
    """The stop signal behind an exception that wraps it (``__cause__``/``__context__``)."""
    seen: set[int] = set()
    while e is not None and id(e) not in seen:
        if isinstance(e, Interrupted):
            return e
        seen.add(id(e))
        e = e.__cause__ or e.__context__
    return None


def _max_memory(args: argparse.Namespace) -> float | None:
    """The ``--max-memory`` of a command that has it, in bytes."""
    text = getattr(args, "max_memory", None)
    if text is None:
        return None
    from arrayproc.chain.guard import parse_bytes
    return parse_bytes(text)


def _pending_stop(e: BaseException) -> Interrupted | None:
    """The stop behind an exception: one it wraps, or a stop signal that arrived before it
    (an interrupt raised inside an import comes back as that import's ImportError)."""
    stop = _stop_cause(e)
    if stop is None:
        from arrayproc.io.atomic import graceful, stop_requested
        signum = stop_requested()
        if signum is not None and not graceful():
            stop = Interrupted(signum)
    return stop


def _stopped(stop: Interrupted) -> int:
    print(f"arrayproc: error: {stop}; no output written", file=sys.stderr)
    return 128 + stop.signum


def _run(args: argparse.Namespace) -> int:
    try:
        from arrayproc.app.catalogue import resolve_names
        resolve_names(args)  # -c NAME: a shipped chain, tracker, TMA or scenario by name
        from arrayproc.chain.guard import MemoryWatch, run_limit
        with MemoryWatch(run_limit(_max_memory(args))):  # every stage and tracker
            return int(args.func(args) or 0)
    except ArrayprocError as e:
        if _pending_stop(e) is not None:
            return _stopped(_pending_stop(e))
        print(f"arrayproc: error: {' '.join(str(e).split())}", file=sys.stderr)
        return int(getattr(e, "exit_status", 2))
    except Interrupted as e:
        print(f"arrayproc: error: {e}; no output written", file=sys.stderr)
        return 128 + e.signum
    except KeyboardInterrupt:
        print("arrayproc: error: interrupted by SIGINT; no output written", file=sys.stderr)
        return 128 + signal.SIGINT
    except BrokenPipeError:  # e.g. `arrayproc info f.h5 | head`: stop quietly
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 1
    except MemoryError as e:
        if _pending_stop(e) is not None:
            return _stopped(_pending_stop(e))
        from arrayproc.chain.guard import memory_error
        err = memory_error()
        print(f"arrayproc: error: {err}", file=sys.stderr)
        return err.exit_status
    except OSError as e:  # the environment: disk full, permissions, I/O errors
        if _pending_stop(e) is not None:
            return _stopped(_pending_stop(e))
        from arrayproc.io.atomic import WRITE_ERRNOS
        where = f"{e.filename}: " if e.filename else ""
        print(f"arrayproc: error: {where}{e.strerror or e}", file=sys.stderr)
        return EXIT_WRITE if e.errno in WRITE_ERRNOS else 2
    except Exception as e:
        stop = _pending_stop(e)
        if stop is not None:  # a signal raised where Python wraps it (e.g. in __set_name__)
            return _stopped(stop)
        if os.environ.get("ARRAYPROC_DEBUG"):
            raise
        print(f"arrayproc: internal error: {type(e).__name__}: {' '.join(str(e).split())} "
              "(a bug; ARRAYPROC_DEBUG=1 shows the traceback)", file=sys.stderr)
        return EX_SOFTWARE


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``arrayproc`` with ``argv`` (default ``sys.argv[1:]``); returns the exit status.

    The start time is stamped on the parsed arguments (``args.started``, perf_counter) for the
    summary line that long commands print when they end (:mod:`arrayproc.app.progress`).
    """
    started = time.perf_counter()
    from arrayproc.io.atomic import clear_stop, discard_all
    clear_stop()
    old = _install_handlers()
    early = list(_early.EARLY)
    _early.EARLY.clear()
    old_show = warnings.showwarning
    warnings.showwarning = _show_warning
    old_unraisable = sys.unraisablehook
    sys.unraisablehook = _quiet_unraisable(old_unraisable)
    try:
        try:
            if early:  # a signal during start-up, before the handlers: the same stop
                raise Interrupted(early[0])
            args = build_parser().parse_args(argv)
            args.started = started
            from arrayproc.app import logs
            restore_logs = logs.configure(logs.level_of(getattr(args, "quiet", False),
                                                        getattr(args, "verbose", 0)))
            try:
                ensure_numba_cache()
                return _run(args)
            finally:
                restore_logs()
        except Interrupted as e:  # a signal while parsing or reporting
            print(f"arrayproc: error: {e}; no output written", file=sys.stderr)
            return 128 + e.signum
        except Exception as e:  # a signal inside an import of the parser's modules
            stop = _pending_stop(e)  # comes back as that import's ImportError
            if stop is None:
                raise
            return _stopped(stop)
    finally:
        for s in old:
            signal.signal(s, signal.SIG_IGN)
        discard_all()
        for s, h in old.items():
            signal.signal(s, h)  # type: ignore[arg-type]
        warnings.showwarning = old_show
        sys.unraisablehook = old_unraisable


def command() -> None:
    """The ``arrayproc`` executable: :func:`main`, then exit with its status.

    After a stop signal the process ends with ``os._exit`` once the streams are flushed: the
    signal may have interrupted a library mid-construction (numba compiling through
    llvmlite), and the finalisers of such half-built objects would print tracebacks at
    interpreter shutdown, after the one error line. Every output was already removed by
    :func:`main` and inputs are only read, so nothing is left for the finalisers to do.
    """
    status = main()
    if status > 128:  # 128 + N: stopped by signal N
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (OSError, ValueError):
                pass
        os._exit(status)
    sys.exit(status)


if __name__ == "__main__":  # pragma: no cover
    command()
