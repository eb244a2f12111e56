"""Tracking components with declared parameters (after Stone Soup's ``Base``/``Property``).

A component class lists its parameters once, ``params = {name: Param(kind, default, doc)}``
(:class:`arrayproc.config.Param`); the constructor takes them as keywords, checks kind and
value, stores them as attributes and calls :meth:`Component._setup`. Bad values raise
:class:`arrayproc.errors.ConfigError` naming the component and the key, so a tracker TOML maps
straight onto components.
"""

from __future__ import annotations

import inspect
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

    def __init_subclass__(cls, **kw: Any) -> None:
        """Give each component class the signature and a numpydoc ``Parameters`` section of
        its declared parameters (``help(UKF)``, ``inspect.signature(UKF)``)."""
        super().__init_subclass__(**kw)
        schema = Schema(cls.all_params())
        if "__init__" in cls.__dict__:
            cls.__signature__ = None  # type: ignore[attr-defined]  # its own, not a base's
        elif schema:
            cls.__signature__ = schema.signature()  # type: ignore[attr-defined]
            doc = inspect.cleandoc(cls.__doc__ or "")
            if "Parameters\n----------" not in doc:
                cls.__doc__ = (doc + "\n\n" + schema.numpydoc()).lstrip()

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
