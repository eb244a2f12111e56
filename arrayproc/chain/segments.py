"""Segments of a long recording: the warm-up margin a segment needs before its start so that
independent segments concatenate into the result of one long run."""

from __future__ import annotations

from arrayproc.chain.graph import ChainSpec, set_rates


def warmup_margin(spec: ChainSpec, fs: float) -> float:
    """Warm-up (s) a segment needs before its start: along each path from the reader, the
    stages' margins added up; the longest path counts."""
    set_rates(spec, fs)
    margin: dict[str | None, float] = {None: 0.0}
    for stage, src in zip(spec.stages, spec.inputs):
        margin[stage.name] = margin[src] + stage.warmup_seconds(stage.fs_in)
    return float(max(margin.values()))
