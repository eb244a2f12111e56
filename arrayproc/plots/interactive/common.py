"""What the report's sections share: figure defaults, sonar orientation, truth, notes."""

from __future__ import annotations

from typing import Any

import numpy as np

from arrayproc.io.text import as_text
from arrayproc.plots._passive import true_bearings  # noqa: F401  (the sections' import)

#: Width of a full-width figure (px); heights are set per figure.
WIDTH = 1100
#: Tools of every figure: pan and wheel zoom on by default (docs/architecture.md, report).
TOOLS = "pan,wheel_zoom,box_zoom,reset,save"
#: Port red and starboard green, as navigation lights.
PORT, STBD = "#d62728", "#2ca02c"
#: Colours of truth sources (dashed).
TRUTH_COLOURS = ("#ff7f0e", "#e377c2", "#17becf", "#bcbd22", "#8c564b")


def figure(name: str, title: str, x_label: str, y_label: str, height: int = 400,
           width: int = WIDTH, time_down: tuple[float, float] | None = None, **kw: Any):
    """A Bokeh figure named ``name`` (the browser test finds it by name) with labelled axes;
    ``time_down`` (t0, t1) makes the y axis time running down (sonar orientation)."""
    from bokeh.models import Range1d
    from bokeh.plotting import figure as bfigure
    if time_down is not None:
        t0, t1 = time_down
        kw["y_range"] = Range1d(start=t1, end=t0, name=f"{name}_y")
    f = bfigure(name=name, title=title, width=width, height=height, tools=TOOLS,
                active_scroll="wheel_zoom", output_backend="canvas", **kw)
    f.xaxis.axis_label = x_label
    f.yaxis.axis_label = y_label
    f.toolbar.logo = None
    return f


def heading(title: str, text: str = "", level: int = 2):
    """A section heading with a paragraph under it (a Bokeh Div)."""
    from bokeh.models import Div
    body = f"<p style='max-width:{WIDTH}px'>{text}</p>" if text else ""
    return Div(text=f"<h{level}>{title}</h{level}>{body}", width=WIDTH)


def notes(lines: list[str]):
    """The decimation notes of a section as a small Div (None when nothing was reduced)."""
    from bokeh.models import Div
    lines = [s for s in lines if s]
    if not lines:
        return None
    return Div(text="<p style='font-size:85%;color:#555'>Decimated for the page: "
               + " ".join(lines) + "</p>", width=WIDTH)


def truth_recording(path: str):
    """The recording at ``path`` when it exists and holds ``/truth/sources``, else None."""
    from arrayproc.plots._passive import open_truth_recording
    return open_truth_recording({"source": path}) if path else None


def source_recording(root: dict[str, Any]) -> str:
    """The recording a products or tracks file was made from (``recording``, else ``source``
    when that is not itself a products file)."""
    from pathlib import Path
    for key in ("recording", "source"):
        p = as_text(root.get(key, ""))
        if p and Path(p).is_file():
            from arrayproc.errors import FormatError
            from arrayproc.io.products import is_products
            try:
                if not is_products(p):
                    return p
            except (FormatError, OSError):  # not HDF5 at all: not a recording either
                continue
    return ""


def finite_range(*arrays: np.ndarray, pad: float = 0.0) -> tuple[float, float]:
    """(min, max) over the finite values of the arrays, widened by ``pad`` each side."""
    v = np.concatenate([np.asarray(a, float).reshape(-1) for a in arrays] or [np.zeros(1)])
    v = v[np.isfinite(v)]
    if v.size == 0:
        return 0.0, 1.0
    lo, hi = float(v.min()), float(v.max())
    if hi <= lo:
        hi = lo + 1.0
    return lo - pad, hi + pad


def colour_span(v: np.ndarray) -> tuple[float, float]:
    """Colour scale of SNR points: the 2nd to the 98th percentile of the finite values."""
    v = np.asarray(v, float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return 0.0, 1.0
    lo, hi = (float(x) for x in np.percentile(v, [2, 98]))
    return lo, max(hi, lo + 1.0)
