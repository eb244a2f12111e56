"""Tracking components with declared parameters (after Stone Soup's ``Base``/``Property``).

A component class lists its parameters once, ``params = {name: Param(kind, default, doc)}``
(:class:`arrayproc.config.Param`); the constructor takes them as keywords, checks kind and
value, stores them as attributes and calls :meth:`Component._setup`. Bad values raise
:class:`arrayproc.errors.ConfigError` naming the component and the key, so a tracker TOML maps
straight onto components.
"""

from __future__ import annotations

from typing import Any, ClassVar

from arrayproc.config import Param, Schema

__all__ = ["Component", "Param"]


class Component:
    """Base of motion models, measurement models and filters."""

    name: ClassVar[str] = "component"
    params: ClassVar[dict[str, Param]] = {}

    def __init__(self, **kwargs: Any) -> None:
        Schema(self.all_params()).apply(self, kwargs, self.name)
        self._setup()

    @classmethod
    def all_params(cls) -> dict[str, Param]:
        """Declared parameters of the class and its bases (subclasses override)."""
        out: dict[str, Param] = {}
        for c in reversed(cls.__mro__):
            out.update(getattr(c, "params", {}) or {})
        return out

    def _setup(self) -> None:
        """Derived quantities once the parameters are set (override)."""

    def __repr__(self) -> str:
        kv = ", ".join(f"{k}={getattr(self, k)!r}" for k in self.all_params())
        return f"{type(self).__name__}({kv})"
