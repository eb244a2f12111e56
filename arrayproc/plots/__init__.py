"""Plots a sonar analyst reads: BTR, LOFAR, range-Doppler, tracks, RMSE curves.

Each kind lives in its own module with two layers:

* ``draw_<kind>(data…, ax=None, …) -> Figure`` draws from data (a products group and the
  file's root attributes, or arrays) on a matplotlib ``Axes`` (or a sequence of them for a
  multi-panel plot) and returns its ``Figure``; without ``ax`` it makes a pyplot figure of the
  plot's size, so it shows in a notebook or a window with the user's backend;
* ``plot_<kind>(path, out_png, **options)``, registered for ``kind``, reads a products (or
  tracks) file and writes the image: it draws on a :class:`matplotlib.figure.Figure` that no
  pyplot manager holds (:func:`write_figure`), so writing files needs no GUI backend and none is
  forced at import. :func:`plot_file` dispatches on ``kind``.
"""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Callable, Mapping
from typing import Any

PLOTTERS: dict[str, Callable[..., Any]] = {}

#: Keyword arguments of :class:`matplotlib.figure.Figure` (the rest go to ``subplots``).
_FIGURE_KEYS = ("figsize", "dpi", "layout", "constrained_layout")


def register_plot(kind: str) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """Decorator: make ``f(path, out_png, **options)`` the plotter of ``kind``."""
    def deco(f: Callable[..., Any]) -> Callable[..., Any]:
        PLOTTERS[kind] = f
        return f
    return deco


def _load() -> None:
    for m in pkgutil.iter_modules(__path__):
        importlib.import_module(f"{__name__}.{m.name}")


def plot_file(path: str, out_png: str, kind: str, limits: Any = None, **options: Any) -> None:
    """Draw product ``kind`` of the file at ``path`` into ``out_png``.

    Parameters
    ----------
    path : str
        Products or tracks file.
    out_png : str
        Image file; matplotlib picks the format from its extension.
    kind : str
        A registered plot kind (``btr``, ``lofar``, ``track``, …).
    limits : arrayproc.plots.limits.Limits, optional
        Time and frequency limits (``--t0/--t1/--fmin/--fmax``), honoured by every time or
        frequency axis (:mod:`arrayproc.plots.limits`).
    **options
        The plotter's options (``range_db``, ``beam``, ``truth``, …).
    """
    from arrayproc.errors import ArrayprocError
    from arrayproc.plots.limits import CURRENT, Limits
    _load()
    if kind not in PLOTTERS:
        raise ArrayprocError(f"plot: unknown kind {kind!r} (known: {', '.join(sorted(PLOTTERS))})")
    token = CURRENT.set(limits or Limits())
    try:
        PLOTTERS[kind](path, out_png, **options)
    finally:
        CURRENT.reset(token)


def subplots(ax: Any, layout: Mapping[str, Any]) -> tuple[Any, Any, bool]:
    """The figure to draw on and its axes: those of ``ax`` when given (a matplotlib ``Axes``,
    or an array or sequence of them), else a new pyplot figure made with ``layout``
    (``figsize``, ``dpi``, ``nrows``, ``ncols``, ``gridspec_kw``, …).

    Returns
    -------
    (Figure, axes, bool)
        The figure, the axes (as given, or as ``pyplot.subplots`` returns them) and whether
        the figure is new (then the caller lays it out when done: :func:`finish`).
    """
    if ax is not None:
        first = ax
        while not hasattr(first, "figure"):
            first = first.flat[0] if hasattr(first, "flat") else first[0]
        return first.figure, ax, False
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(**layout)
    return fig, axes, True


def finish(fig: Any, new: bool, layout: Mapping[str, Any]) -> Any:
    """Lay out a figure :func:`subplots` made (``tight_layout`` unless ``layout`` asks for
    another engine); a figure the caller gave is left as it is. Returns ``fig``."""
    if new and not any(k in layout for k in ("layout", "constrained_layout")):
        fig.tight_layout()
    return fig


def write_figure(draw: Callable[[Any], Any], out: str, layout: Mapping[str, Any],
                 **save: Any) -> None:
    """Draw into an image file: a :class:`~matplotlib.figure.Figure` outside pyplot (no
    backend, no window, nothing left open) with the axes ``layout`` asks for, given to
    ``draw``, laid out as :func:`finish` does and saved to ``out`` (``save``: ``savefig``
    options such as ``dpi``)."""
    from matplotlib.figure import Figure
    fig = Figure(**{k: v for k, v in layout.items() if k in _FIGURE_KEYS})
    axes = fig.subplots(**{k: v for k, v in layout.items() if k not in _FIGURE_KEYS})
    draw(axes)
    from arrayproc.plots.limits import apply
    apply(fig)  # --t0/--t1/--fmin/--fmax on every time and frequency axis
    finish(fig, True, layout)
    fig.savefig(out, **save)
