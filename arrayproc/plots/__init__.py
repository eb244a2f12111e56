"""Plots a sonar analyst reads: BTR, LOFAR, range-Doppler, tracks, RMSE curves.

Each kind lives in its own module and registers a function ``f(path, out_png, **options)`` that
draws it from a products (or tracks) file; :func:`plot_file` dispatches on ``kind``.
"""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Callable
from typing import Any

import matplotlib

matplotlib.use("Agg")  # files only; never needs a display

PLOTTERS: dict[str, Callable[..., Any]] = {}


def register_plot(kind: str) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """Decorator: make ``f(path, out_png, **options)`` the plotter of ``kind``."""
    def deco(f: Callable[..., Any]) -> Callable[..., Any]:
        PLOTTERS[kind] = f
        return f
    return deco


def _load() -> None:
    for m in pkgutil.iter_modules(__path__):
        importlib.import_module(f"{__name__}.{m.name}")


def plot_file(path: str, out_png: str, kind: str, **options: Any) -> None:
    """Draw product ``kind`` of the file at ``path`` into ``out_png``."""
    from arrayproc.errors import ArrayprocError
    _load()
    if kind not in PLOTTERS:
        raise ArrayprocError(f"plot: unknown kind {kind!r} (known: {', '.join(sorted(PLOTTERS))})")
    PLOTTERS[kind](path, out_png, **options)
