"""What the package ships and declares, for the command line: ``arrayproc stages [TYPE]``
(every stage type, or one type's keys, from the stages' declarations) and the shipped chains,
trackers, TMA and scenario files that ``-c NAME`` (and ``simulate NAME``) accept by name.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from arrayproc.errors import ConfigError

#: (command, argument) -> (data folder, what it holds) for the arguments that accept a name
SHIPPED: dict[tuple[str, str], tuple[str, str]] = {
    ("process", "chain"): ("chains", "chain"),
    ("batch", "chain"): ("chains", "chain"),
    ("track", "config"): ("trackers", "tracker"),
    ("tma", "config"): ("tma", "TMA"),
    ("simulate", "scenario"): ("scenarios", "scenario"),
}


def shipped_names(folder: str) -> list[str]:
    """Names (file stems) of the TOML files shipped in a data folder."""
    from arrayproc.data import data_path
    d = data_path(folder)
    return sorted(p.stem for p in Path(d).glob("*.toml")) if Path(d).is_dir() else []


def resolve_config(value: str, folder: str, what: str) -> str:
    """A configuration given on the command line: a path if it exists, else a shipped name.

    Parameters
    ----------
    value : str
        What the user typed: a path, or the name of a shipped file (``towed_passive``, with or
        without ``.toml``).
    folder : str
        The data folder of the shipped files (``chains``, ``trackers``, ``tma``, ``scenarios``).
    what : str
        What it is, for the message.

    Returns
    -------
    str
        The path to read.

    Raises
    ------
    ConfigError
        Neither a file nor a shipped name: the message lists the shipped names.
    """
    if os.path.exists(value) or os.sep in value or (os.altsep and os.altsep in value):
        return value
    from arrayproc.data import data_path
    stem = value[:-5] if value.endswith(".toml") else value
    names = shipped_names(folder)
    if stem in names:
        return str(data_path(folder, stem + ".toml"))
    raise ConfigError(f"{value}: no such {what} file, nor a shipped {what} (shipped: "
                      f"{', '.join(names) or 'none'})")


def resolve_names(args: argparse.Namespace) -> None:
    """Replace a shipped name by its path in the parsed arguments of a command."""
    for (cmd, dest), (folder, what) in SHIPPED.items():
        if getattr(args, "command", None) == cmd and isinstance(getattr(args, dest, None), str):
            setattr(args, dest, resolve_config(getattr(args, dest), folder, what))


def _domains(cls: type) -> str:
    accepts = getattr(cls, "accepts", None)
    src = "any" if accepts is None else " | ".join(sorted(d.value for d in accepts))
    out = cls.produces.value if cls.produces is not None else (
        "same" if accepts is None or len(accepts) > 1 else next(iter(accepts)).value)
    return f"{src} -> {out}"


def stage_lines() -> list[str]:
    """One line per stage type: type, input -> output domains, summary."""
    from arrayproc.chain.stage import STAGES
    from arrayproc.stages import load_all
    load_all()
    rows = [(k, _domains(c), c.params.summary) for k, c in sorted(STAGES.items())]
    w0 = max(len(r[0]) for r in rows)
    w1 = max(len(r[1]) for r in rows)
    return [f"{k:<{w0}}  {d:<{w1}}  {s}" for k, d, s in rows]


def stage_keys(kind: str) -> list[str]:
    """The keys of one stage type: name, type, default, unit, doc (one line each)."""
    from arrayproc.chain.stage import STAGES
    from arrayproc.stages import load_all
    load_all()
    if kind not in STAGES:
        raise ConfigError(f"no stage type {kind!r} (known: {', '.join(sorted(STAGES))})")
    cls = STAGES[kind]
    lines = [f"{kind}: {cls.params.summary}", f"domains: {_domains(cls)}"]
    rows = [(k, p.type_text.replace("\\|", "|"), p.default_text, p.unit or "-",
             " ".join(p.doc.split())) for k, p in cls.params.items()]
    if not rows:
        return lines + ["no keys"]
    head = ("key", "type", "default", "unit", "doc")
    ws = [max(len(r[i]) for r in [head, *rows]) for i in range(4)]
    for r in [head, *rows]:
        lines.append("  ".join(f"{c:<{w}}" for c, w in zip(r[:4], ws)) + "  " + r[4])
    return lines


def cmd_stages(args: argparse.Namespace) -> int:
    print("\n".join(stage_keys(args.type) if args.type else stage_lines()))
    return 0


def add_parser(sub) -> None:
    """Add ``arrayproc stages [TYPE]``, and say in the help of every argument of
    :data:`SHIPPED` that it also takes a shipped file's name (this module is listed after the
    other command modules, so their parsers exist)."""
    for (cmd, dest), (folder, what) in SHIPPED.items():
        parser = sub.choices.get(cmd)
        names = shipped_names(folder)
        shown = ", ".join(names) if len(names) <= 12 else "see arrayproc data-dir"
        for action in getattr(parser, "_actions", []):
            if action.dest == dest and "shipped" not in (action.help or ""):
                action.help = (action.help or f"{what} TOML file") + \
                    f", or the name of a shipped one ({shown})"
    s = sub.add_parser("stages", help="list the chain stage types, or one type's keys")
    s.add_argument("type", nargs="?", metavar="TYPE",
                   help="a stage type: print its keys with type, default, unit and doc")
    s.add_argument("-q", "--quiet", action="store_true", help="accepted for symmetry: "
                   "this command prints only what it is asked for")
    s.set_defaults(func=cmd_stages)
