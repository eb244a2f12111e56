"""``simulate → process → track → tma`` in one process, through the same library functions
the commands call, for the end-to-end evaluations of :mod:`arrayproc.evaluate`.

The command layer (:mod:`arrayproc.app`) adds argument checks, progress bars and the memory
guard on top of these calls; the evaluation layer sits below it (``docs/architecture.md``,
layers), so the end-to-end scenarios call the library here instead. What they produce is what
the commands produce from the same files: the same functions, in the same order.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

from arrayproc.io.products import ProductsWriter
from arrayproc.io.recording import Recording
from arrayproc.sim.run import simulate_file
from arrayproc.stages import load_chain
from arrayproc.track.batch.inputs import run_tma_inputs
from arrayproc.track.runner import run_tracker

__all__ = ["process", "simulate", "tma", "track"]


def simulate(scenario: str, output: str, duration: float | None = None,
             warn: Callable[[str], None] | None = None, seed: int | None = None) -> str:
    """``arrayproc simulate SCENARIO -o OUTPUT [--duration S] [--seed N]``; returns
    ``output``."""
    simulate_file(scenario, output, seed=seed, duration=duration, warn=warn)
    return output


def process(recording: str, chain: str, output: str,
            warn: Callable[[str], None] | None = None) -> int:
    """``arrayproc process RECORDING -c CHAIN -o OUTPUT``; returns the time blocks read."""
    from arrayproc.chain import run_chain
    spec = load_chain(chain)
    source = str(Path(recording).resolve())
    with Recording(recording) as r, ProductsWriter(output, source=source,
                                                   chain=spec.text) as out:
        return run_chain(r, spec, out, log=warn)


def track(products: str, config: str, output: str) -> None:
    """``arrayproc track PRODUCTS -c TRACKER -o OUTPUT``."""
    run_tracker(products, config, output)


def tma(products: str | Sequence[str], config: str, output: str) -> None:
    """``arrayproc tma PRODUCTS_OR_TRACKS… -c TMA -o OUTPUT``: one solution per confirmed
    track of a tracks file, the solutions of a products file, or (``method = "cross_fix"``)
    of several arrays' files (:func:`arrayproc.track.batch.inputs.run_tma_inputs`)."""
    run_tma_inputs(products, config, output)
