"""A chain as a graph: the TOML builder that validates every stage before any data is read,
and the wiring of stage generators with fan-outs and a scheduler that keeps memory bounded.
"""

from __future__ import annotations

import collections
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass
from typing import Any

from arrayproc.chain.block import Block
from arrayproc.chain.domains import Domain
from arrayproc.chain.guard import named
from arrayproc.chain.stage import STAGES, Stage
from arrayproc.config import Param, Schema, parse_toml, positive
from arrayproc.errors import ConfigError


@dataclass
class ChainSpec:
    """A validated chain: stages in order, each with the name of its input (None = reader)."""

    stages: list[Stage]
    inputs: list[str | None]
    block: int = 8192
    text: str = ""
    array_shape: str = "rigid"

    def names(self) -> list[str]:
        return [s.name for s in self.stages]


INPUT_KEYS = {"block": Param("int", 8192, "samples per time block read", check=positive,
                             unit="samples"),
              "array_shape": Param("str", "rigid", "element positions: the file's (rigid) or "
                                   "threaded on the /nav track (a water-pulled towed array)",
                                   choices=("rigid", "threaded"))}


def parse_chain(config: Mapping[str, Any] | str, text: str = "") -> tuple[Mapping[str, Any], str]:
    """A chain given as TOML text or as a parsed mapping, as ``(mapping, text)``."""
    if isinstance(config, str):
        return parse_toml(config, "chain"), config
    return config, text


def build_chain(config: Mapping[str, Any] | str, text: str = "") -> ChainSpec:
    """Build and validate a chain from a parsed TOML mapping (or TOML text).

    Every key is checked before any data is read: unknown top-level tables, unknown stage
    types, unknown or mistyped keys, missing required keys and dangling ``input`` names raise
    :class:`ConfigError` naming the stage and key.
    """
    config, text = parse_chain(config, text)
    for key in config:
        if key not in ("input", "stage"):
            raise ConfigError(f"chain: unknown top-level key {key!r} (expected [input] and "
                              "[[stage]] tables)")
    inp = config.get("input", {})
    if not isinstance(inp, Mapping):
        raise ConfigError("chain: [input] must be a table")
    reader = Schema(INPUT_KEYS).check(inp, "chain: [input]")
    block, shape = reader["block"], reader["array_shape"]
    tables = config.get("stage", [])
    if not isinstance(tables, list) or not tables:
        raise ConfigError("chain: needs at least one [[stage]] table")
    stages: list[Stage] = []
    inputs: list[str | None] = []
    names: set[str] = set()
    domains: dict[str | None, Domain] = {None: Domain.TIME}  # the reader yields time blocks
    for i, table in enumerate(tables):
        if not isinstance(table, Mapping):
            raise ConfigError(f"chain: stage {i + 1} is not a table")
        table = dict(table)
        kind = table.pop("type", None)
        if kind is None:
            raise ConfigError(f"chain: stage {i + 1}: missing required key 'type'")
        if not isinstance(kind, str):
            raise ConfigError(f"chain: stage {i + 1}: key 'type' must be a string, got {kind!r}")
        if kind not in STAGES:
            known = ", ".join(sorted(STAGES)) or ("none registered: import the stage modules "
                                                  "first, arrayproc.stages.load_all()")
            raise ConfigError(f"chain: stage {i + 1}: unknown stage type {kind!r} (known: "
                              f"{known})")
        name = table.pop("name", None) or kind
        if not isinstance(name, str):
            raise ConfigError(f"chain: stage {i + 1}: key 'name' must be a string")
        if "/" in name or name in (".", ".."):
            raise ConfigError(f"chain: stage {i + 1}: key 'name' {name!r} must be a plain name "
                              "(no '/', not '.' or '..'): it names the products group")
        if name in names:
            raise ConfigError(f"chain: stage {i + 1}: duplicate stage name {name!r} (give each "
                              "stage of the same type a distinct 'name')")
        src = table.pop("input", None)
        if src is not None and not isinstance(src, str):
            raise ConfigError(f"chain: stage {name!r}: key 'input' must be a stage name, got "
                              f"{src!r}")
        if src is not None and src not in names:
            raise ConfigError(f"chain: stage {name!r}: key 'input' names {src!r}, which is not "
                              "an earlier stage")
        if src is None and stages:
            src = stages[-1].name
        stage = STAGES[kind](name=name, **table)
        stage.upstream = next((s for s in stages if s.name == src), None)
        stage.check_input(domains[src])  # the wiring, from the stages' declarations
        domains[name] = stage.output_domain(domains[src])
        stages.append(stage)
        inputs.append(src)
        names.add(name)
    return ChainSpec(stages, inputs, block, text, shape)


class _Fanout:
    """Lets several consumers read one upstream iterator, each at its own pace."""

    def __init__(self, upstream: Iterator[Block], n: int) -> None:
        self.upstream = upstream
        self.queues: list[collections.deque] = [collections.deque() for _ in range(n)]
        self.done = False

    def _pull(self) -> bool:
        if self.done:
            return False
        try:
            item = next(self.upstream)
        except StopIteration:
            self.done = True
            return False
        for q in self.queues:
            q.append(item)
        return True

    def reader(self, i: int) -> Iterator[Block]:
        q = self.queues[i]
        while True:
            if not q and not self._pull():
                return
            yield q.popleft()


def compose(spec: ChainSpec, source: Iterable[Block]) -> tuple[list[Iterator[Block]],
                                                               list[list[collections.deque]]]:
    """Wire the stages into generators.

    Returns the leaf iterators (stages nobody reads) and, per leaf, the fan-out queues on its
    path from the reader, which :func:`drive` uses to schedule the leaves.
    """
    consumers: dict[str | None, list[int]] = collections.defaultdict(list)
    for i, src in enumerate(spec.inputs):
        consumers[src].append(i)
    outputs: dict[str | None, Iterator[Block]] = {None: iter(source)}
    queues_of: dict[str | None, list[collections.deque]] = {None: []}
    feeds: dict[int, Iterator[Block]] = {}
    feed_queues: dict[int, list[collections.deque]] = {}

    def feed_from(src: str | None) -> None:
        users = consumers.get(src, [])
        if len(users) == 1:
            feeds[users[0]] = outputs[src]
            feed_queues[users[0]] = queues_of[src]
        elif len(users) > 1:
            fan = _Fanout(outputs[src], len(users))
            for j, u in enumerate(users):
                feeds[u] = fan.reader(j)
                feed_queues[u] = queues_of[src] + [fan.queues[j]]

    feed_from(None)
    for i, stage in enumerate(spec.stages):
        outputs[stage.name] = named(stage.name, stage(feeds[i]))  # the memory guard
        queues_of[stage.name] = feed_queues[i]
        feed_from(stage.name)
    leaves = [s.name for s in spec.stages if not consumers.get(s.name)]
    return [outputs[n] for n in leaves], [queues_of[n] for n in leaves]


def drive(leaves: list[Iterator[Block]], queues: list[list[collections.deque]],
          on_block: Callable[[], None] | None = None) -> None:
    """Pull every leaf to exhaustion, always advancing the leaf that lags most (the longest
    fan-out queue on its path), so queues stay short and memory stays bounded by a few blocks
    per branch whatever the file length."""
    active = list(range(len(leaves)))
    while active:
        i = max(active, key=lambda j: max((len(q) for q in queues[j]), default=0))
        try:
            next(leaves[i])
        except StopIteration:
            active.remove(i)
            continue
        if on_block is not None:
            on_block()


def set_rates(spec: ChainSpec, fs: float) -> None:
    """Give every stage its input sample rate (``fs_in``), following the branches."""
    rates: dict[str | None, float] = {None: fs}
    for stage, src in zip(spec.stages, spec.inputs):
        stage.fs_in = rates[src]
        rates[stage.name] = stage.output_rate(stage.fs_in)
