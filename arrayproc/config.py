"""One validator for every TOML the user writes: chains, scenarios, trackers, TMA and batch
configurations. A :class:`Param` declares a key (kind, default, unit, doc, check) once; a
:class:`Schema` is the declared keys of one table, which checks a mapping (never a path: each
file is parsed once, by :func:`read_toml`) and renders the same declarations as a call
signature, a numpydoc ``Parameters`` section and a Markdown key table. Every error names the
file, the table and the key, in one line.
"""

from __future__ import annotations

import inspect
import math
import os
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from arrayproc.errors import ConfigError

try:  # Python 3.11+
    import tomllib
except ModuleNotFoundError:  # Python 3.10: the same parser, published as tomli
    import tomli as tomllib  # type: ignore[no-redef]

_REQUIRED = object()


@dataclass(frozen=True)
class Param:
    """A declared stage parameter.

    ``kind`` is one of ``"float"``, ``"int"``, ``"bool"``, ``"str"``, ``"band"`` (two floats,
    lo < hi), ``"floats"`` (list of numbers), ``"table"`` (a TOML table), ``"any"``.
    ``choices`` restricts strings; ``check`` returns an error text or None; ``unit`` is the SI
    unit (or ``"deg"``, ``"dB"``, ``"samples"``...) of the value, for the generated docs.
    """

    kind: str
    default: Any = _REQUIRED
    doc: str = ""
    choices: tuple[Any, ...] | None = None
    check: Callable[[Any], str | None] | None = None
    unit: str = ""

    @property
    def required(self) -> bool:
        return self.default is _REQUIRED

    def convert(self, where: str, value: Any, sep: str = ": ") -> Any:
        """The value checked and converted; a ConfigError ``where + sep + what is wrong``."""
        k = self.kind
        bad = ConfigError(f"{where}{sep}expected {k}, got {value!r}")
        if k == "float":
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise bad
            value = float(value)
            if not np.isfinite(value):
                raise ConfigError(f"{where}{sep}must be finite, got {value!r}")
        elif k == "int":
            if isinstance(value, bool) or not isinstance(value, int):
                raise bad
        elif k == "bool":
            if not isinstance(value, bool):
                raise bad
        elif k == "str":
            if not isinstance(value, str):
                raise bad
        elif k in ("band", "floats"):
            if not isinstance(value, (list, tuple)) or not all(
                    isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
                raise bad
            value = [float(v) for v in value]
            if k == "band" and (len(value) != 2 or not value[0] < value[1]):
                raise ConfigError(f"{where}{sep}expected [lo, hi] with lo < hi, got {value!r}")
        elif k == "table":
            if not isinstance(value, Mapping):
                raise bad
            value = dict(value)
        if self.choices is not None and value not in self.choices:
            raise ConfigError(f"{where}{sep}must be one of {', '.join(map(str, self.choices))}, "
                              f"got {value!r}")
        if self.check is not None:
            msg = self.check(value)
            if msg:
                raise ConfigError(f"{where}{sep}{msg}")
        return value


    @property
    def type_text(self) -> str:
        """The kind as the docs write it (``float``, ``[lo, hi]``, ``"a" | "b"``...)."""
        if self.choices is not None and self.kind == "str":
            return " \\| ".join(f'"{c}"' for c in self.choices)
        return {"band": "[lo, hi]", "floats": "list of float"}.get(self.kind, self.kind)

    @property
    def default_text(self) -> str:
        """The default as TOML would write it; ``required`` or ``—`` (none: derived)."""
        if self.required:
            return "required"
        return "—" if self.default is None else toml_value(self.default)


def toml_value(v: Any) -> str:
    """A value as it is written in a TOML file (for the generated docs and messages)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return f'"{v}"'
    if isinstance(v, float) and v.is_integer() and abs(v) < 1e15:
        return f"{v:.1f}"
    if isinstance(v, Mapping):
        return "{" + ", ".join(f"{k} = {toml_value(x)}" for k, x in v.items()) + "}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    return repr(v)


class Schema(Mapping):
    """The declared keys of one TOML table (a chain stage, ``[tracker]``, ``[tma]``...).

    A read-only mapping name -> :class:`Param`. :meth:`check` validates a mapping of values;
    :meth:`signature`, :meth:`numpydoc` and :meth:`markdown` render the same declarations.

    Parameters
    ----------
    params : mapping of str to Param
        The keys, in documentation order.
    summary : str
        One line saying what the table configures.
    """

    def __init__(self, params: Mapping[str, Param], summary: str = "") -> None:
        self.params = dict(params)
        self.summary = summary

    def __getitem__(self, key: str) -> Param:
        return self.params[key]

    def __iter__(self):
        return iter(self.params)

    def __len__(self) -> int:
        return len(self.params)

    def __or__(self, other: Mapping[str, Param]) -> Schema:
        return Schema({**self.params, **other}, self.summary)

    def check(self, values: Mapping[str, Any], where: str, *, prefix: str = "",
              of: str = "", allow: Iterable[str] = ()) -> dict[str, Any]:
        """Every declared key's value, converted and checked, defaults filled in.

        Parameters
        ----------
        values : mapping
            The table as parsed (or keyword arguments).
        where : str
            Start of every message: the file and table, or the stage (``"stage 'cbf'"``).
        prefix : str
            The table's dotted path, written before each key in messages: with a prefix
            (``"tma."``) a message reads ``"{where}: tma.window must be >= 0, got -1.0"``,
            without one ``"{where}: key 'window': must be >= 0, got -1.0"``.
        of : str
            Added after an unknown key's name (``" for type 'cbf'"``).
        allow : iterable of str
            Keys of ``values`` that are not declared but are read elsewhere.

        Returns
        -------
        dict
            Key -> value for every declared key. A value of None given for a key whose
            default is None counts as absent.

        Raises
        ------
        ConfigError
            Unknown key (with the known ones), missing required key, bad value.
        """
        if not isinstance(values, Mapping):
            raise ConfigError(f"{where}: must be a table, got {values!r}")
        allowed = set(allow)

        def name(key: str) -> str:
            return prefix + key if prefix else repr(key)

        for key in values:
            if key not in self.params and key not in allowed:
                raise ConfigError(f"{where}: unknown key {name(key)}{of} "
                                  f"(known: {', '.join(sorted(self.params)) or 'none'})")
        out: dict[str, Any] = {}
        for key, p in self.params.items():
            v = values.get(key)
            if key in values and (v is not None or p.default is not None):
                out[key] = p.convert(f"{where}: {prefix}{key}" if prefix else
                                     f"{where}: key {key!r}", v, sep=" " if prefix else ": ")
            elif p.required:
                raise ConfigError(f"{where}: missing required key {name(key)}")
            else:
                out[key] = p.default
        return out

    def apply(self, obj: Any, values: Mapping[str, Any], where: str, **kw: Any) -> None:
        """:meth:`check` the values and set each as an attribute of ``obj``."""
        for key, v in self.check(values, where, **kw).items():
            setattr(obj, key, v)

    def signature(self, first: Iterable[inspect.Parameter] = ()) -> inspect.Signature:
        """A call signature with one keyword-only parameter per key (after ``first``)."""
        ps = list(first)
        for key, p in self.params.items():
            default = inspect.Parameter.empty if p.required else p.default
            ps.append(inspect.Parameter(key, inspect.Parameter.KEYWORD_ONLY, default=default,
                                        annotation=_ANNOTATIONS.get(p.kind, Any)))
        return inspect.Signature(ps)

    def numpydoc(self, indent: str = "") -> str:
        """A numpydoc ``Parameters`` section: each key with type, default, unit and doc."""
        lines = ["Parameters", "----------"]
        for key, p in self.params.items():
            typ = p.type_text.replace("\\|", "|")
            dflt = ("required" if p.required else "optional" if p.default is None
                    else f"default {p.default_text}")
            unit = f", {p.unit}" if p.unit else ""
            lines.append(f"{key} : {typ}, {dflt}{unit}")
            lines.append(f"    {p.doc or '(undocumented)'}")
        return "\n".join(indent + ln if ln else ln for ln in lines)

    def markdown(self, first: str | None = None) -> str:
        """A Markdown table of the keys: key, type, default, unit, description.

        ``first`` (e.g. a stage type) adds a first column, filled on the first row only, so
        several schemas stack into one table (see :func:`markdown_header`).
        """
        rows = []
        for i, (key, p) in enumerate(self.params.items()):
            cells = [f"`{key}`", p.type_text, p.default_text.replace("|", "\\|"),
                     p.unit or "—", _md(p.doc)]
            if first is not None:
                cells.insert(0, f"`{first}`" if i == 0 else "")
            rows.append("| " + " | ".join(cells) + " |")
        if first is None:
            rows = markdown_header(False) + rows
        return "\n".join(rows)


def markdown_header(first: bool, first_name: str = "type") -> list[str]:
    """Header lines of a :meth:`Schema.markdown` table."""
    cols = ["key", "type", "default", "unit", "description"]
    if first:
        cols.insert(0, first_name)
    return ["| " + " | ".join(cols) + " |", "|" + " --- |" * len(cols)]


def _md(text: str) -> str:
    return " ".join(text.split()).replace("|", "\\|")


_ANNOTATIONS: dict[str, Any] = {"float": float, "int": int, "bool": bool, "str": str,
                                "band": list[float], "floats": list[float], "table": dict}


def positive(v: Any) -> str | None:
    """Check for :class:`Param`: the value must be > 0."""
    return None if v > 0 else f"must be > 0, got {v}"


def read_toml(path: str | os.PathLike, what: str) -> tuple[dict[str, Any], str]:
    """Read a TOML file, with the same one-line errors for every kind of configuration.

    Parameters
    ----------
    path : str or path-like
        The file.
    what : str
        What it is (``"chain"``, ``"scenario"``, ``"tracker"``, ...), for the messages.

    Returns
    -------
    (dict, str)
        The parsed document and its text.

    Raises
    ------
    ConfigError
        Missing, unreadable, not UTF-8 or not TOML.
    """
    try:
        with open(path, "rb") as f:
            raw = f.read()
    except FileNotFoundError:
        raise ConfigError(f"{path}: no such {what} file") from None
    except IsADirectoryError:
        raise ConfigError(f"{path}: is a directory, not a {what} file") from None
    except OSError as e:
        raise ConfigError(f"{path}: cannot read {what} file ({e.strerror})") from None
    try:
        text = raw.decode()
    except UnicodeDecodeError as e:
        raise ConfigError(f"{path}: invalid TOML ({e})") from None
    return parse_toml(text, str(path)), text


def parse_toml(text: str, where: str) -> dict[str, Any]:
    """Parse TOML text (the one parse site of the package: every file goes through here once).

    Parameters
    ----------
    text : str
        The document.
    where : str
        The file (or ``"chain"`` for text given in Python), for the message.

    Raises
    ------
    ConfigError
        ``"{where}: invalid TOML (...)"``.
    """
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise ConfigError(f"{where}: invalid TOML ({e})") from None


class Table:
    """A TOML table being read with typed getters (scenarios, trackers, TMA and batch files).

    Every getter names the file, the table and the key in its error; :meth:`done` reports the
    first key that no getter asked for (a typo). Chain stages declare their keys with
    :class:`Param` instead, checked the same way by :class:`arrayproc.chain.Stage`.
    """

    def __init__(self, data: Any, where: str, file: str) -> None:
        if not isinstance(data, dict):
            raise ConfigError(f"{file}: [{where}] must be a table")
        self.d = data
        self.where = where
        self.file = file
        self.used: set[str] = set()

    def err(self, key: str, msg: str) -> ConfigError:
        return ConfigError(f"{self.file}: [{self.where}] {key}: {msg}")

    def has(self, key: str) -> bool:
        return key in self.d

    def raw(self, key: str, default: Any = None) -> Any:
        self.used.add(key)
        return self.d.get(key, default)

    def num(self, key: str, default: float | None = None, *, required: bool = False,
            positive: bool = False, nonneg: bool = False) -> float | None:
        self.used.add(key)
        if key not in self.d:
            if required:
                raise self.err(key, "missing (a number is required)")
            return default
        v = self.d[key]
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise self.err(key, f"must be a number, got {type(v).__name__} {v!r}")
        v = float(v)
        if not math.isfinite(v):
            raise self.err(key, "must be finite")
        if positive and v <= 0:
            raise self.err(key, f"must be > 0, got {v}")
        if nonneg and v < 0:
            raise self.err(key, f"must be >= 0, got {v}")
        return v

    def int_(self, key: str, default: int | None = None, *, required: bool = False,
             minimum: int | None = None) -> int | None:
        self.used.add(key)
        if key not in self.d:
            if required:
                raise self.err(key, "missing (an integer is required)")
            return default
        v = self.d[key]
        if isinstance(v, bool) or not isinstance(v, int):
            raise self.err(key, f"must be an integer, got {type(v).__name__} {v!r}")
        if minimum is not None and v < minimum:
            raise self.err(key, f"must be >= {minimum}, got {v}")
        return int(v)

    def str_(self, key: str, default: str | None = None, *, required: bool = False,
             choices: tuple[str, ...] | None = None) -> str | None:
        self.used.add(key)
        if key not in self.d:
            if required:
                raise self.err(key, "missing (a string is required)")
            return default
        v = self.d[key]
        if not isinstance(v, str):
            raise self.err(key, f"must be a string, got {type(v).__name__} {v!r}")
        if choices is not None and v not in choices:
            raise self.err(key, f"must be one of {', '.join(choices)}, got {v!r}")
        return v

    def bool_(self, key: str, default: bool) -> bool:
        self.used.add(key)
        if key not in self.d:
            return default
        v = self.d[key]
        if not isinstance(v, bool):
            raise self.err(key, f"must be true or false, got {v!r}")
        return v

    def vec(self, key: str, n: int | None = None, default: Any = None, *,
            required: bool = False) -> np.ndarray | None:
        self.used.add(key)
        if key not in self.d:
            if required:
                raise self.err(key, "missing (a list of numbers is required)")
            return None if default is None else np.asarray(default, float)
        v = self.d[key]
        ok = isinstance(v, list) and all(
            isinstance(x, (int, float)) and not isinstance(x, bool) for x in v)
        if not ok or (n is not None and len(v) != n):
            what = f"{n} numbers" if n is not None else "a list of numbers"
            raise self.err(key, f"must be {what}, got {v!r}")
        a = np.asarray(v, dtype=float)
        if not np.all(np.isfinite(a)):
            raise self.err(key, "must be finite")
        return a

    def matrix(self, key: str, ncol: int, *, required: bool = False) -> np.ndarray | None:
        self.used.add(key)
        if key not in self.d:
            if required:
                raise self.err(key, f"missing (a list of [{ncol} numbers] rows is required)")
            return None
        v = self.d[key]
        try:
            a = np.asarray(v, dtype=float)
        except (TypeError, ValueError):
            a = None
        if (a is None or a.ndim != 2 or a.shape[1] != ncol or a.shape[0] == 0
                or any(isinstance(x, bool) for row in v for x in row)):
            raise self.err(key, f"must be a list of rows of {ncol} numbers, got {v!r}")
        if not np.all(np.isfinite(a)):
            raise self.err(key, "must be finite")
        return a

    def sub(self, key: str, required: bool = False) -> Table | None:
        self.used.add(key)
        if key not in self.d:
            if required:
                raise ConfigError(f"{self.file}: [{self._child(key)}] is missing")
            return None
        return Table(self.d[key], self._child(key), self.file)

    def subs(self, key: str) -> list[Table]:
        """An array of tables (``[[where.key]]``), possibly empty."""
        self.used.add(key)
        v = self.d.get(key, [])
        if isinstance(v, dict):
            v = [v]
        if not isinstance(v, list):
            raise self.err(key, "must be an array of tables")
        return [Table(x, f"{self._child(key)}[{i}]", self.file) for i, x in enumerate(v)]

    def _child(self, key: str) -> str:
        return f"{self.where}.{key}" if self.where else key

    def done(self) -> None:
        unknown = sorted(set(self.d) - self.used)
        if unknown:
            where = f"[{self.where}]" if self.where else "top level"
            raise ConfigError(f"{self.file}: {where}: unknown key {unknown[0]!r}")


def resolve_beside(path: str, rel_to: str) -> str:
    """A path named inside a file (a recording named by a products file, a products file named
    by a configuration) as it resolves for the user.

    Parameters
    ----------
    path : str
        The path as written; empty, absolute or existing paths are returned unchanged.
    rel_to : str
        The file that names it: a relative ``path`` that does not exist from the working
        directory is looked up beside this file.

    Returns
    -------
    str
        The path beside ``rel_to`` when that exists, else ``path`` unchanged (the caller's
        open then reports it missing).
    """
    if not path or os.path.isabs(path) or os.path.exists(path):
        return path
    cand = os.path.join(os.path.dirname(os.path.abspath(rel_to)), path)
    return cand if os.path.exists(cand) else path
