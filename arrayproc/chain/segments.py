"""Segments of a long recording: the warm-up margin a segment needs before its start so that
independent segments concatenate into the result of one long run, the plan that cuts a
recording into such segments, and the merge of the segments' products files into one.

docs/scale-out.md. A segment ``[t_start, t_stop)`` is run by :func:`arrayproc.chain.run_chain`
from ``t_start − margin`` to ``t_stop + margin`` and its products writer keeps the rows whose
``time`` falls in the segment, so the segments' rows partition the single run's rows.

Bit-exactness. Stages that frame their input on the stream's absolute sample grid (``cbf``
frames start at multiples of ``hop``; ``integrate`` groups snapshots at multiples of N_B;
``dft_filter``'s overlap-save frames start at multiples of its output block M, less half a
filter) compute every kept row from the same samples in the same order wherever the read
starts, so their rows are equal bit for bit, provided the warm-up margin covers a whole
frame (a frame partly before the read sees zeros there, and its rounding differs). A stage
whose frames are laid from the first sample read computes the same values only up to
rounding unless every read starts on its frame grid; such a stage may declare the grid with a
method ``segment_grid(fs, n_channels) -> int`` (input samples), and :func:`plan_segments` puts every
segment's read start on the least common multiple of the declared grids (each taken at the
recording rate). Stages without the method are assumed to need no alignment.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from arrayproc.chain.graph import ChainSpec, set_rates
from arrayproc.errors import ConfigError, FormatError


def warmup_margin(spec: ChainSpec, fs: float) -> float:
    """Warm-up (s) a segment needs before its start: along each path from the reader, the
    stages' margins added up; the longest path counts.

    Parameters
    ----------
    spec : ChainSpec
        The chain.
    fs : float
        Recording sample rate, Hz.

    Returns
    -------
    float
        Margin, s.
    """
    set_rates(spec, fs)
    margin: dict[str | None, float] = {None: 0.0}
    for stage, src in zip(spec.stages, spec.inputs):
        margin[stage.name] = margin[src] + stage.warmup_seconds(stage.fs_in)
    return float(max(margin.values()))


def read_grid(spec: ChainSpec, fs: float, n_channels: int) -> int:
    """The grid (recording samples) every segment's first read sample must lie on for the
    stages' frames to coincide with a single run's: the least common multiple of the grids the
    stages declare through ``segment_grid(fs_in, n_channels)``, each scaled by the decimation
    between the recording and the stage's input.

    Parameters
    ----------
    spec : ChainSpec
        The chain.
    fs : float
        Recording sample rate, Hz.
    n_channels : int
        Channels read.

    Returns
    -------
    int
        Grid, samples at ``fs`` (1 when no stage declares one).
    """
    set_rates(spec, fs)
    grid = 1
    for stage in spec.stages:
        declare = getattr(stage, "segment_grid", None)
        if declare is None:
            continue
        g = int(declare(stage.fs_in, n_channels))
        ratio = fs / stage.fs_in
        if g < 1 or abs(ratio - round(ratio)) > 1e-9:
            raise ConfigError(f"stage {stage.name!r}: cannot align segments (grid {g}, input "
                              f"rate {stage.fs_in:g} Hz from {fs:g} Hz)")
        grid = math.lcm(grid, g * int(round(ratio)))
    return grid


@dataclass(frozen=True)
class Segment:
    """One segment of a recording: rows with ``t_start <= time < t_stop`` (s since the start;
    ``None`` = the recording's start / end)."""

    index: int
    t_start: float | None
    t_stop: float | None
    #: Where the read ends (s, before the chain's own margin is added): past ``t_stop`` by one
    #: read grid and one margin, so that batches of frames that hold kept rows are whole.
    t_read_stop: float | None = None

    @property
    def window(self) -> tuple[float, float]:
        """The products writer's time window (s)."""
        return (-math.inf if self.t_start is None else self.t_start,
                math.inf if self.t_stop is None else self.t_stop)


def plan_segments(spec: ChainSpec, fs: float, n_samples: int, n_channels: int,
                  segment_s: float, grid: int = 1) -> list[Segment]:
    """Cut a recording into segments of about ``segment_s`` seconds.

    Boundary k sits near ``k · segment_s``, moved (by less than one read grid) so that the
    segment's first read sample ``(t_k − margin) · fs`` lies on :func:`read_grid`; the first
    segment starts at the recording's start, the last ends at its end. A segment's read goes
    on one grid and one margin past its stop (``t_read_stop``): a stage that works on batches
    of frames laid from the read's start (``cbf``'s GEMM batches, whose rounding depends on the
    batch's size) then computes the frames of kept rows in whole batches, as the single run.

    Parameters
    ----------
    spec : ChainSpec
        The chain (its warm-up margin and read grid).
    fs : float
        Recording sample rate, Hz.
    n_samples : int
        Recording length, samples.
    n_channels : int
        Channels read.
    segment_s : float
        Target segment length, s (> 0).
    grid : int
        A further read grid (recording samples) the caller knows of, combined with the
        stages' own (least common multiple).

    Returns
    -------
    list of Segment
        In time order, covering the recording without gaps or overlaps.
    """
    if not segment_s > 0:
        raise ConfigError(f"--segment-s must be > 0 s, got {segment_s}")
    margin = warmup_margin(spec, fs)
    grid = math.lcm(int(grid), read_grid(spec, fs, n_channels))
    m_samples = margin * fs
    bounds: list[float] = []
    k = 1
    while k * segment_s * fs < n_samples:
        j = int(round((k * segment_s * fs - m_samples) / grid))
        t = (j * grid + m_samples) / fs
        if j > 0 and t * fs < n_samples and (not bounds or t > bounds[-1]):
            bounds.append(t)
        k += 1
    edges: list[float | None] = [None, *bounds, None]
    extra = grid / fs + margin
    return [Segment(i, edges[i], edges[i + 1],
                    None if edges[i + 1] is None else edges[i + 1] + extra)
            for i in range(len(edges) - 1)]


def _is_rows(d: h5py.Dataset) -> bool:
    """Row columns are resizable along their first axis; static datasets (axes) are not."""
    return d.maxshape is not None and len(d.maxshape) > 0 and d.maxshape[0] is None


def _same(a: Any, b: Any) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    if a.shape != b.shape or a.dtype != b.dtype:
        return False
    if a.dtype.kind in "fc":
        return bool(np.array_equal(a, b, equal_nan=True))
    return bool(np.array_equal(a, b))


def merge_products(parts: Sequence[str | os.PathLike], output: str | os.PathLike,
                   source: str, chain: str) -> None:
    """Merge the products files of consecutive segments into one file like a single run's.

    Row columns are concatenated in segment order; static datasets (axes) and group attributes
    must agree between the parts that hold them. The output is written atomically and marked
    ``complete``.

    Parameters
    ----------
    parts : sequence of path
        The segments' products files, in time order, each ``complete``.
    output : path
        The merged products file.
    source : str
        The recording, as the single run records it (its resolved path).
    chain : str
        The chain's TOML text.

    Raises
    ------
    FormatError
        A part is incomplete, or parts disagree on a static dataset or attribute.
    """
    from arrayproc.io.products import ProductsWriter

    files = [h5py.File(p, "r") for p in parts]
    try:
        for p, f in zip(parts, files):
            if not bool(f.attrs.get("complete", False)):
                raise FormatError(f"{p}: segment products file is not complete")
        names: list[str] = []
        for f in files:
            names += [n for n, g in f.items() if isinstance(g, h5py.Group) and n not in names]
        units = files[0].attrs.get("units") if files else None
        with ProductsWriter(output, source=source, chain=chain,
                            attrs=None if units is None else {"units": units}) as out:
            for name in names:
                have = [(p, f[name]) for p, f in zip(parts, files) if name in f]
                _merge_group(name, have, out)
    finally:
        for f in files:
            f.close()


def _merge_group(name: str, have: list[tuple[Any, h5py.Group]], out: Any) -> None:
    p0, g0 = have[0]
    attrs = dict(g0.attrs)
    for p, g in have[1:]:
        a = dict(g.attrs)
        if a.keys() != attrs.keys() or not all(_same(a[k], attrs[k]) for k in a):
            raise FormatError(f"{p}: group {name!r}: attributes differ from {p0}'s")
    kind, stage = attrs.pop("kind", ""), attrs.pop("stage", name)
    kind = kind.decode() if isinstance(kind, bytes) else str(kind)
    stage = stage.decode() if isinstance(stage, bytes) else str(stage)
    w = out.group(name, kind, stage, **attrs)
    rows: dict[str, list[np.ndarray]] = {}
    static: dict[str, np.ndarray] = {}
    for p, g in have:
        for k, d in g.items():
            if not isinstance(d, h5py.Dataset):
                continue
            if _is_rows(d):
                rows.setdefault(k, []).append(d[()])
            elif k in static:
                if not _same(static[k], d[()]):
                    raise FormatError(f"{p}: dataset {name}/{k} differs from the first "
                                      "segment's")
            else:
                static[k] = d[()]
                w.set(k, static[k], **dict(d.attrs))
    if rows:
        # a segment that found nothing holds its kind's empty table, whose trailing sizes
        # (channels, beams) may be 0: only segments with rows are joined
        rows = {k: [a for a in v if a.shape[0]] or v[:1] for k, v in rows.items()}
        cols = {k: np.concatenate(v) if len(v) > 1 else v[0] for k, v in rows.items()}
        if len({v.shape[0] for v in cols.values()}) != 1:
            raise FormatError(f"group {name!r}: segments give columns of unequal length")
        w.append(**cols)


def part_path(output: str | os.PathLike, segment: Segment) -> Path:
    """Where segment ``segment`` of ``output`` is written before the merge."""
    out = Path(output)
    return out.with_name(f".{out.stem}.seg{segment.index:04d}.h5")
