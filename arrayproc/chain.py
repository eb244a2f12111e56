"""Processing chains: stages (generator transforms over blocks), their registry, the TOML
builder that validates a whole chain before any data is read, and the runner.

A chain file looks like::

    [input]
    block = 8192            # samples per time block read from the recording (default 8192)

    [[stage]]
    type = "dft_filter"
    band = [100.0, 2000.0]

    [[stage]]
    type = "cbf"
    name = "cbf"
    nfft = 2048

    [[stage]]
    type = "power"
    input = "dft_filter"    # a branch reading the same upstream as cbf

Each stage reads the stage before it unless it names an ``input``. The reader feeds
non-overlapping time blocks of ``block`` samples; stages that need overlapping frames
(FFT-based ones) frame the stream themselves with :class:`FrameBuffer`, so block boundaries
never show in the results.

Segments: :func:`run_chain` accepts ``t_start``/``t_stop``; it reads from a warm-up margin
before the start to the same margin after the stop (the sum of the stages' ``warmup_seconds``
along the longest path, each at its input rate) and the products writer keeps only rows whose
time falls in the segment, so independent segments (e.g. on Dask workers) concatenate into the
result of one long run.
"""

from __future__ import annotations

import collections
import sys
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from .block import Block
from .errors import ConfigError

try:  # Python 3.11+
    import tomllib
except ModuleNotFoundError:  # pragma: no cover
    import tomli as tomllib  # type: ignore[no-redef]

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


@dataclass
class RunContext:
    """What a stage may use besides its input blocks."""

    products: Any = None  # ProductsWriter or None
    sound_speed: float = 1500.0
    recording: Any = None  # the Recording (metadata and truth), or None
    log: Callable[[str], None] = field(default=lambda msg: print(msg, file=sys.stderr))


class Stage(ABC):
    """Base of all stages: a generator transform ``blocks -> blocks``.

    Subclasses declare ``kind`` (the TOML ``type``), ``params`` (name -> :class:`Param`) and
    implement :meth:`process`. Parameters arrive validated as attributes. A stage that writes
    products asks ``self.products(kind)`` for its group writer.
    """

    kind: ClassVar[str] = ""
    params: ClassVar[dict[str, Param]] = {}

    def __init__(self, name: str | None = None, **values: Any) -> None:
        self.name = name or self.kind
        where = f"stage {self.name!r}"
        for key in values:
            if key not in self.params:
                raise ConfigError(f"{where}: unknown key {key!r} for type {self.kind!r} "
                                  f"(known: {', '.join(sorted(self.params)) or 'none'})")
        for key, p in self.params.items():
            if key in values:
                setattr(self, key, p.convert(f"{where}: key {key!r}", values[key]))
            elif p.required:
                raise ConfigError(f"{where}: missing required key {key!r}")
            else:
                setattr(self, key, p.default)
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
        return self.process(blocks)


STAGES: dict[str, type[Stage]] = {}


def register(cls: type[Stage]) -> type[Stage]:
    """Class decorator: make a stage type available to chain files under ``cls.kind``."""
    if not cls.kind:
        raise TypeError(f"{cls.__name__} has no kind")
    STAGES[cls.kind] = cls
    return cls


def _load_stage_modules() -> None:
    from . import stages  # noqa: F401  (imports every stage module, which registers them)


@dataclass
class ChainSpec:
    """A validated chain: stages in order, each with the name of its input (None = reader)."""

    stages: list[Stage]
    inputs: list[str | None]
    block: int = 8192
    text: str = ""

    def names(self) -> list[str]:
        return [s.name for s in self.stages]


INPUT_KEYS = {"block": Param("int", 8192, "samples per time block read", check=positive)}


def build_chain(config: Mapping[str, Any] | str, text: str = "") -> ChainSpec:
    """Build and validate a chain from a parsed TOML mapping (or TOML text).

    Every key is checked before any data is read: unknown top-level tables, unknown stage
    types, unknown or mistyped keys, missing required keys and dangling ``input`` names raise
    :class:`ConfigError` naming the stage and key.
    """
    _load_stage_modules()
    if isinstance(config, str):
        text = config
        try:
            config = tomllib.loads(config)
        except tomllib.TOMLDecodeError as e:
            raise ConfigError(f"chain: invalid TOML ({e})") from None
    for key in config:
        if key not in ("input", "stage"):
            raise ConfigError(f"chain: unknown top-level key {key!r} (expected [input] and "
                              "[[stage]] tables)")
    inp = config.get("input", {})
    if not isinstance(inp, Mapping):
        raise ConfigError("chain: [input] must be a table")
    for key in inp:
        if key not in INPUT_KEYS:
            raise ConfigError(f"chain: [input]: unknown key {key!r}")
    block = INPUT_KEYS["block"].convert("chain: [input]: key 'block'", inp.get("block", 8192))
    tables = config.get("stage", [])
    if not isinstance(tables, list) or not tables:
        raise ConfigError("chain: needs at least one [[stage]] table")
    stages: list[Stage] = []
    inputs: list[str | None] = []
    names: set[str] = set()
    for i, table in enumerate(tables):
        if not isinstance(table, Mapping):
            raise ConfigError(f"chain: stage {i + 1} is not a table")
        table = dict(table)
        kind = table.pop("type", None)
        if kind is None:
            raise ConfigError(f"chain: stage {i + 1}: missing required key 'type'")
        if kind not in STAGES:
            raise ConfigError(f"chain: stage {i + 1}: unknown stage type {kind!r} (known: "
                              f"{', '.join(sorted(STAGES))})")
        name = table.pop("name", None) or kind
        if not isinstance(name, str):
            raise ConfigError(f"chain: stage {i + 1}: key 'name' must be a string")
        if name in names:
            raise ConfigError(f"chain: stage {i + 1}: duplicate stage name {name!r} (give each "
                              "stage of the same type a distinct 'name')")
        src = table.pop("input", None)
        if src is not None and src not in names:
            raise ConfigError(f"chain: stage {name!r}: key 'input' names {src!r}, which is not "
                              "an earlier stage")
        if src is None and stages:
            src = stages[-1].name
        stage = STAGES[kind](name=name, **table)
        stage.upstream = next((s for s in stages if s.name == src), None)
        stages.append(stage)
        inputs.append(src)
        names.add(name)
    return ChainSpec(stages, inputs, block, text)


def load_chain(path: str) -> ChainSpec:
    """Read and validate a chain TOML file."""
    try:
        with open(path, "rb") as f:
            raw = f.read()
    except FileNotFoundError:
        raise ConfigError(f"{path}: no such chain file") from None
    except OSError as e:
        raise ConfigError(f"{path}: cannot read chain file ({e.strerror})") from None
    try:
        text = raw.decode()
        cfg = tomllib.loads(text)
    except (UnicodeDecodeError, tomllib.TOMLDecodeError) as e:
        raise ConfigError(f"{path}: invalid TOML ({e})") from None
    try:
        return build_chain(cfg, text)
    except ConfigError as e:
        raise ConfigError(f"{path}: {e}") from None


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
        outputs[stage.name] = stage(feeds[i])
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


class FrameBuffer:
    """Cuts a stream of contiguous time blocks into frames of ``nfft`` samples every ``hop``.

    Frames are positioned on the stream's absolute sample grid (frame k starts at sample
    k·hop of the stream), so results never depend on how the reader cut the blocks. Only the
    ``meta["n_valid"]`` real samples of each block are used.
    """

    def __init__(self, nfft: int, hop: int) -> None:
        self.nfft, self.hop = int(nfft), int(hop)
        self._buf: np.ndarray | None = None
        self._buf_start = 0  # absolute sample index of _buf[0]
        self._next = None  # absolute sample index of the next frame start

    def push(self, block: Block) -> tuple[np.ndarray, np.ndarray]:
        """Add a time block; return complete frames (k, nfft, n_ch) and their start samples (k,)."""
        x = block.data[: block.meta.get("n_valid", block.data.shape[0])]
        s0 = int(block.meta.get("sample0", round(block.t0 * block.fs)))
        if self._next is None:
            self._next = -(-s0 // self.hop) * self.hop  # first grid point at or after s0
        contiguous = self._buf is not None and self._buf_start + self._buf.shape[0] == s0
        if not contiguous or self._buf.shape[0] == 0:
            self._buf, self._buf_start = x, s0
        else:
            self._buf = np.concatenate([self._buf, x])
        off = self._next - self._buf_start
        avail = self._buf.shape[0] - off
        k = 0 if avail < self.nfft else (avail - self.nfft) // self.hop + 1
        if k:
            view = np.lib.stride_tricks.sliding_window_view(self._buf[off:], self.nfft, axis=0)
            frames = view[: (k - 1) * self.hop + 1: self.hop].transpose(0, 2, 1)
        else:
            frames = np.zeros((0, self.nfft, self._buf.shape[1]), dtype=self._buf.dtype)
        starts = self._next + self.hop * np.arange(k)
        self._next += k * self.hop
        drop = max(0, min(self._next - self._buf_start, self._buf.shape[0]))
        frames = np.ascontiguousarray(frames)  # detach from the buffer before trimming it
        self._buf = self._buf[drop:]
        self._buf_start += drop
        return frames, starts


def set_rates(spec: ChainSpec, fs: float) -> None:
    """Give every stage its input sample rate (``fs_in``), following the branches."""
    rates: dict[str | None, float] = {None: fs}
    for stage, src in zip(spec.stages, spec.inputs):
        stage.fs_in = rates[src]
        rates[stage.name] = stage.output_rate(stage.fs_in)


def warmup_margin(spec: ChainSpec, fs: float) -> float:
    """Warm-up (s) a segment needs before its start: along each path from the reader, the
    stages' margins added up; the longest path counts."""
    set_rates(spec, fs)
    margin: dict[str | None, float] = {None: 0.0}
    for stage, src in zip(spec.stages, spec.inputs):
        margin[stage.name] = margin[src] + stage.warmup_seconds(stage.fs_in)
    return float(max(margin.values()))


def run_chain(recording: Any, spec: ChainSpec, products: Any = None,
              t_start: float | None = None, t_stop: float | None = None,
              progress: bool = False, log: Callable[[str], None] | None = None) -> int:
    """Run a chain over a recording (or the segment [t_start, t_stop) s of it).

    Returns the number of time blocks read. Product rows outside the segment are dropped by
    the products writer's time window (set it to the same segment).
    """
    ctx = RunContext(products=products, sound_speed=recording.sound_speed, recording=recording)
    if log is not None:
        ctx.log = log
    for s in spec.stages:
        s.bind(ctx)
    fs = recording.fs
    set_rates(spec, fs)
    margin = warmup_margin(spec, fs)
    a = 0.0 if t_start is None else max(0.0, t_start - margin)
    start = int(round(a * fs))
    # Read past the end by the same margin: a window stamped before t_stop may reach beyond
    # it (rows after t_stop are dropped by the products writer's time window).
    stop = recording.n_samples if t_stop is None else min(recording.n_samples,
                                                          int(round((t_stop + margin) * fs)))
    n = recording.n_blocks(spec.block, spec.block, start, stop)
    source: Iterable[Block] = recording.blocks(spec.block, spec.block, start, stop)
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(total=n, unit="block", desc="process", leave=False)

        def counted(it: Iterable[Block]) -> Iterator[Block]:
            for b in it:
                yield b
                bar.update(1)
        source = counted(source)
    leaves, queues = compose(spec, source)
    try:
        drive(leaves, queues)
    finally:
        if bar is not None:
            bar.close()
    return n
