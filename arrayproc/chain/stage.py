"""Stages: generator transforms over blocks, built from checked parameters, and the registry
that maps a chain file's ``type`` to a stage class.

The engine knows no stage by name: stage modules register themselves with :func:`register`
when imported, and the application layer imports them (:func:`arrayproc.stages.load_all`).
"""

from __future__ import annotations

import inspect
import logging
import re
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any, ClassVar

from arrayproc.chain.block import Block
from arrayproc.chain.domains import Domain
from arrayproc.config import Param, Schema
from arrayproc.errors import ConfigError


@dataclass
class RunContext:
    """What a stage may use besides its input blocks."""

    products: Any = None  # ProductsWriter or None
    sound_speed: float = 1500.0
    recording: Any = None  # the Recording (metadata and truth), or None
    log: Callable[[str], None] = field(default=logging.getLogger("arrayproc.chain").warning)


class Stage(ABC):
    """Base of all stages: a generator transform ``blocks -> blocks``.

    Subclasses declare ``kind`` (the TOML ``type``), ``params`` (name -> :class:`Param`) and
    implement :meth:`process`. Parameters arrive validated as attributes. A stage that writes
    products asks ``self.products(kind)`` for its group writer.
    """

    kind: ClassVar[str] = ""
    params: ClassVar[dict[str, Param]] = {}
    #: Domains of the blocks this stage reads (None: any).
    accepts: ClassVar[frozenset[Domain] | None] = None
    #: Domain of the blocks it yields (None: it passes its input's blocks on).
    produces: ClassVar[Domain | None] = None

    def output_domain(self, input_domain: Domain) -> Domain:
        """Domain of the blocks this stage yields when it reads ``input_domain``."""
        return self.produces if self.produces is not None else input_domain

    def check_input(self, domain: Domain) -> None:
        """Raise ConfigError unless the stage accepts blocks of ``domain``."""
        if self.accepts is not None and domain not in self.accepts:
            want = " or ".join(sorted(d.value for d in self.accepts))
            got = getattr(domain, "value", domain)
            raise ConfigError(f"stage {self.name!r} (type {self.kind!r}) needs {want} blocks, "
                              f"but its input yields {got} blocks")

    def __init__(self, name: str | None = None, **values: Any) -> None:
        self.name = name or self.kind
        schema = self.params if isinstance(self.params, Schema) else Schema(self.params)
        schema.apply(self, values, f"stage {self.name!r}", of=f" for type {self.kind!r}")
        self.ctx = RunContext()
        self.validate()

    def validate(self) -> None:  # noqa: B027 - optional hook, empty by default
        """Cross-parameter checks; raise ConfigError naming the key."""

    def bind(self, ctx: RunContext) -> None:
        """Called once by the runner before data flows."""
        self.ctx = ctx

    def products(self, kind: str, **attrs: Any):
        """The products group this stage writes to (named after the stage)."""
        if self.ctx.products is None:
            return None
        return self.ctx.products.group(self.name, kind, self.name, **attrs)

    #: The stage this one reads (None: the reader), and its input sample rate (Hz); both set
    #: by :func:`build_chain` / :func:`run_chain` before data flows.
    upstream: Stage | None = None
    fs_in: float = 0.0

    def warmup_seconds(self, fs: float) -> float:
        """Input needed before this stage's output is valid (s), for segmented runs; ``fs`` is
        the stage's input sample rate."""
        return 0.0

    def output_rate(self, fs: float) -> float:
        """Sample rate (Hz) of the time series this stage passes on, given its input rate."""
        return fs

    def snapshot_seconds(self) -> float | None:
        """Time between this stage's output snapshots (s), when it emits snapshots; by default
        that of the stage it reads."""
        return self.upstream.snapshot_seconds() if self.upstream is not None else None

    @abstractmethod
    def process(self, blocks: Iterator[Block]) -> Iterator[Block]:
        """The stage's generator transform (subclasses)."""

    def __call__(self, blocks: Iterator[Block]) -> Iterator[Block]:
        return self.process(self._checked(blocks) if self.accepts is not None else blocks)

    def _checked(self, blocks: Iterator[Block]) -> Iterator[Block]:
        for b in blocks:
            if b.domain not in self.accepts:
                self.check_input(b.domain)
            yield b


STAGES: dict[str, type[Stage]] = {}


def register(cls: type[Stage]) -> type[Stage]:
    """Class decorator: make a stage type available to chain files under ``cls.kind``.

    The declared ``params`` become the class's :class:`~arrayproc.config.Schema`, and the
    class gets a constructor whose signature and docstring list every key with its type,
    default, unit and doc (``help(CBF)``), generated from the same declarations.
    """
    if not cls.kind:
        raise TypeError(f"{cls.__name__} has no kind")
    cls.params = Schema(cls.params, _summary(cls))
    _document(cls)
    STAGES[cls.kind] = cls
    return cls


def _summary(cls: type[Stage]) -> str:
    """The first paragraph of the class docstring, without its pointer to the module doc."""
    first = (inspect.getdoc(cls) or "").split("\n\n")[0].replace("\n", " ")
    first = re.sub(r"\s*(;\s*|\()see (the )?module doc(string)?\)?", "", first).rstrip(".")
    return first + "." if first else ""


def _document(cls: type[Stage]) -> None:
    """Give a stage class a constructor whose signature and docstring come from its keys."""
    schema: Schema = cls.params  # type: ignore[assignment]
    if "__init__" not in cls.__dict__:
        def __init__(self, name: str | None = None, **values: Any) -> None:
            Stage.__init__(self, name, **values)
        __init__.__qualname__ = f"{cls.__qualname__}.__init__"
        cls.__init__ = __init__  # type: ignore[method-assign]
    first = [inspect.Parameter("self", inspect.Parameter.POSITIONAL_OR_KEYWORD),
             inspect.Parameter("name", inspect.Parameter.POSITIONAL_OR_KEYWORD, default=None,
                               annotation="str | None")]
    section = schema.numpydoc()
    name_doc = ("name : str, optional\n    The stage's name in the chain and of its products "
                f"group (default ``{cls.kind!r}``).")
    section = section.replace("----------\n", "----------\n" + name_doc + "\n", 1)
    init = cls.__init__
    init.__signature__ = schema.signature(first)  # type: ignore[attr-defined]
    init.__doc__ = (f"A ``{cls.kind}`` stage; each key of its chain-file table is a keyword."
                    f"\n\n{section}\n")
    cls.__signature__ = schema.signature(first[1:])  # type: ignore[attr-defined]
    cls.__doc__ = (inspect.cleandoc(cls.__doc__ or "") + "\n\n" + section).lstrip()
