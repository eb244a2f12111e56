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
    lo < hi), ``"floats"`` (list of finite numbers), ``"rows"`` (a non-empty list of equal-length
    rows of finite numbers), ``"table"`` (a TOML table), ``"tables"`` (an array of tables; one
    table counts as an array of one), ``"any"``.
    ``choices`` restricts strings; ``check`` returns an error text or None; ``unit`` is the SI
    unit (or ``"deg"``, ``"dB"``, ``"samples"``...) of the value, for the generated docs;
    ``schema`` declares the keys of a ``"table"``/``"tables"`` value (read by
    :meth:`Section.sub`).
    """

    kind: str
    default: Any = _REQUIRED
    doc: str = ""
    choices: tuple[Any, ...] | None = None
    check: Callable[[Any], str | None] | None = None
    unit: str = ""
    schema: Schema | None = None

    @property
    def required(self) -> bool:
        return self.default is _REQUIRED

    def convert(self, where: str, value: Any, sep: str = ": ") -> Any:
        """The value checked and converted; a ConfigError ``where + sep + what is wrong``."""
        k = self.kind
        what = {"float": "must be a number", "int": "must be an integer",
                "bool": "must be true or false", "str": "must be a string"}
        bad = ConfigError(f"{where}{sep}{what.get(k, f'expected {k}')}, got {value!r}")
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
            if not all(math.isfinite(v) for v in value):
                raise ConfigError(f"{where}{sep}must be finite, got {value!r}")
            if k == "band" and (len(value) != 2 or not value[0] < value[1]):
                raise ConfigError(f"{where}{sep}expected [lo, hi] with lo < hi, got {value!r}")
        elif k == "rows":
            value = _rows(value, bad, where, sep)
        elif k == "table":
            if not isinstance(value, Mapping):
                raise bad
            value = dict(value)
        elif k == "tables":
            value = [value] if isinstance(value, Mapping) else value
            if not isinstance(value, list) or not all(isinstance(x, Mapping) for x in value):
                raise ConfigError(f"{where}{sep}expected an array of tables, got {value!r}")
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
        return {"band": "[lo, hi]", "floats": "list of float", "rows": "list of [float, …]",
                "tables": "array of tables"}.get(self.kind, self.kind)

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
              of: str = "", allow: Iterable[str] = (), table: str | None = None
              ) -> dict[str, Any]:
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
        table : str, optional
            The table's name in a nested file (``"source[0].tonals[1]"``): messages then read
            ``"{where}: [table] key: what is wrong"`` (``"{where}: top level"`` for ``""``).

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
        at = None if table is None else (f"[{table}]" if table else "top level")

        def name(key: str) -> str:
            return prefix + key if prefix else repr(key)

        def site(key: str) -> str:
            if at is not None:
                return f"{where}: {at} {key}"
            return f"{where}: {prefix}{key}" if prefix else f"{where}: key {key!r}"

        for key in values:
            if key not in self.params and key not in allowed:
                head = f"{where}: {at}:" if at is not None else f"{where}:"
                raise ConfigError(f"{head} unknown key {name(key)}{of} "
                                  f"(known: {', '.join(sorted(self.params)) or 'none'})")
        out: dict[str, Any] = {}
        for key, p in self.params.items():
            v = values.get(key)
            if key in values and (v is not None or p.default is not None):
                out[key] = p.convert(site(key), v, sep=" " if prefix and at is None else ": ")
            elif p.required:
                raise ConfigError(f"{site(key)}: missing (required)" if at is not None else
                                  f"{where}: missing required key {name(key)}")
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


def _rows(value: Any, bad: ConfigError, where: str, sep: str) -> list[list[float]]:
    """A ``"rows"`` value: a non-empty list of equal-length lists of finite numbers."""
    def number(x: Any) -> bool:
        return isinstance(x, (int, float)) and not isinstance(x, bool)

    if (not isinstance(value, list) or not value
            or not all(isinstance(r, list) and r and all(number(x) for x in r) for r in value)
            or len({len(r) for r in value}) != 1):
        raise bad
    out = [[float(x) for x in r] for r in value]
    if not all(math.isfinite(x) for r in out for x in r):
        raise ConfigError(f"{where}{sep}must be finite, got {value!r}")
    return out


def positive(v: Any) -> str | None:
    """Check for :class:`Param`: the value must be > 0."""
    return None if v > 0 else f"must be > 0, got {v}"


def non_negative(v: Any) -> str | None:
    """Check for :class:`Param`: the value must be >= 0."""
    return None if v >= 0 else f"must be >= 0, got {v}"


def at_least(lo: float) -> Callable[[Any], str | None]:
    """Check for :class:`Param`: the value must be >= ``lo``."""
    def check(v: Any) -> str | None:
        return None if v >= lo else f"must be >= {lo}, got {v}"
    return check


def length(n: int) -> Callable[[Any], str | None]:
    """Check for a ``"floats"`` :class:`Param`: exactly ``n`` numbers."""
    def check(v: Any) -> str | None:
        return None if len(v) == n else f"must be {n} numbers, got {v!r}"
    return check


def columns(n: int) -> Callable[[Any], str | None]:
    """Check for a ``"rows"`` :class:`Param`: rows of exactly ``n`` numbers."""
    def check(v: Any) -> str | None:
        return None if len(v[0]) == n else f"must be a list of rows of {n} numbers, got {v!r}"
    return check


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


class Section:
    """One table of a nested TOML file (a scenario) checked against its :class:`Schema`.

    On construction every key is checked by :meth:`Schema.check` (unknown keys refused,
    values converted, defaults filled); ``section[key]`` is the checked value. Tables inside
    it (a :class:`Param` of kind ``"table"``/``"tables"`` with a ``schema``) are read with
    :meth:`sub`/:meth:`subs`, checked the same way. Rules across keys (one of two keys,
    a default that depends on another key) stay with the reader, which raises :meth:`err`.

    Parameters
    ----------
    data : mapping
        The table as parsed.
    schema : Schema
        Its declared keys.
    where : str
        The table's dotted path (``"source[1].tonals[0]"``); empty at the top level.
    file : str
        The file, first in every message.
    """

    def __init__(self, data: Any, schema: Schema, where: str, file: str) -> None:
        if not isinstance(data, Mapping):
            raise ConfigError(f"{file}: [{where}] must be a table")
        self.d = data
        self.schema = schema
        self.where = where
        self.file = file
        self.values = schema.check(data, file, table=where)

    def __getitem__(self, key: str) -> Any:
        return self.values[key]

    def err(self, key: str, msg: str) -> ConfigError:
        """The one-line error of ``key`` in this table."""
        return ConfigError(f"{self.file}: [{self.where}] {key}: {msg}")

    def has(self, key: str) -> bool:
        """Whether the file gives ``key`` (a default does not count)."""
        return key in self.d

    def need(self, key: str, why: str = "") -> Any:
        """``self[key]``, which must be given (a key whose need depends on another)."""
        if self.values[key] is None:
            raise self.err(key, f"missing{' (' + why + ')' if why else ''}")
        return self.values[key]

    def sub(self, key: str, required: bool = False) -> Section | None:
        """The sub-table ``key`` checked against its declared schema; None when absent."""
        if key not in self.d:
            if required:
                raise ConfigError(f"{self.file}: [{self._child(key)}] is missing")
            return None
        return Section(self.d[key], self._schema(key), self._child(key), self.file)

    def subs(self, key: str) -> list[Section]:
        """The array of tables ``key`` (``[[where.key]]``), possibly empty."""
        schema = self._schema(key)
        return [Section(x, schema, f"{self._child(key)}[{i}]", self.file)
                for i, x in enumerate(self.values[key] or [])]

    def _schema(self, key: str) -> Schema:
        s = self.schema[key].schema
        if s is None:
            raise TypeError(f"key {key!r} declares no schema for its table")
        return s

    def _child(self, key: str) -> str:
        return f"{self.where}.{key}" if self.where else key


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
