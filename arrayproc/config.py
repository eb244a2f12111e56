"""One validator for every TOML the user writes: chains, scenarios, trackers, TMA and batch
configurations. A :class:`Param` declares a key (kind, default, check); every error names the
file, the table and the key, in one line.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from arrayproc.errors import ConfigError

try:  # Python 3.11+
    import tomllib  # noqa: F401  (re-exported for the loaders)
except ModuleNotFoundError:  # pragma: no cover
    pass  # type: ignore[no-redef]

_REQUIRED = object()


@dataclass(frozen=True)
class Param:
    """A declared stage parameter.

    ``kind`` is one of ``"float"``, ``"int"``, ``"bool"``, ``"str"``, ``"band"`` (two floats,
    lo < hi), ``"floats"`` (list of numbers), ``"table"`` (a TOML table), ``"any"``.
    ``choices`` restricts strings; ``check`` returns an error text or None.
    """

    kind: str
    default: Any = _REQUIRED
    doc: str = ""
    choices: tuple[Any, ...] | None = None
    check: Callable[[Any], str | None] | None = None

    @property
    def required(self) -> bool:
        return self.default is _REQUIRED

    def convert(self, where: str, value: Any) -> Any:
        k = self.kind
        bad = ConfigError(f"{where}: expected {k}, got {value!r}")
        if k == "float":
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise bad
            value = float(value)
            if not np.isfinite(value):
                raise ConfigError(f"{where}: must be finite, got {value!r}")
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
                raise ConfigError(f"{where}: expected [lo, hi] with lo < hi, got {value!r}")
        elif k == "table":
            if not isinstance(value, Mapping):
                raise bad
            value = dict(value)
        if self.choices is not None and value not in self.choices:
            raise ConfigError(f"{where}: must be one of {', '.join(map(str, self.choices))}, "
                              f"got {value!r}")
        if self.check is not None:
            msg = self.check(value)
            if msg:
                raise ConfigError(f"{where}: {msg}")
        return value


def positive(v: Any) -> str | None:
    """Check for :class:`Param`: the value must be > 0."""
    return None if v > 0 else f"must be > 0, got {v}"
