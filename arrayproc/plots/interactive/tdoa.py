"""TDOA section of the report: each channel's delay against time (time running down, ±1σ),
and the localised positions in plan view with their 1σ ellipses and the hydrophones."""

from __future__ import annotations

from typing import Any

import numpy as np

from arrayproc.plots.interactive import decimate as dec
from arrayproc.plots.interactive.common import figure, finite_range
from arrayproc.plots.interactive.tracks import ellipse_params


def delays(g: dict, path: str) -> tuple[list[Any], list[str]]:
    """Delays of every channel to the reference (ms) across, time running down, ±1σ
    whiskers. Returns (layout rows, notes)."""
    from bokeh.models import ColumnDataSource, HoverTool
    from bokeh.palettes import Category10_10

    from arrayproc.io.products import delays_columns
    d = delays_columns(g, path)
    t, tau, sig = d["time"], d["tau"], d["sigma"]
    idx = dec.stride(t.size, dec.POINTS_MAX // max(1, tau.shape[1]))
    notes = [dec.note("Delay rows", dec.factor(t.size, idx.size or 1), "one kept")]
    t0, t1 = finite_range(t, pad=1.0)
    f = figure("delays", f"delays to channel {d['reference']} (±1σ)",
               f"delay relative to channel {d['reference']} (ms)",
               "time (s since recording start)", height=480, width=700, time_down=(t0, t1))
    for ch in range(tau.shape[1]):
        if ch == d["reference"]:
            continue
        c = Category10_10[ch % 10]
        s = sig[idx, ch] * 1e3 if sig is not None else np.zeros(idx.size)
        src = ColumnDataSource({"tau": tau[idx, ch] * 1e3, "time": t[idx],
                                "lo": tau[idx, ch] * 1e3 - s, "hi": tau[idx, ch] * 1e3 + s,
                                "sigma": s}, name=f"delays_ch{ch}")
        f.segment("lo", "time", "hi", "time", source=src, color=c)
        r = f.scatter("tau", "time", source=src, color=c, size=6, legend_label=f"channel {ch}")
        f.add_tools(HoverTool(renderers=[r], tooltips=[
            ("channel", str(ch)), ("delay", "@tau{0.000} ms"), ("σ", "@sigma{0.000} ms"),
            ("time", "@time{0.00} s")]))
    f.legend.click_policy = "hide"
    f.legend.label_text_font_size = "8pt"
    return [f], notes


def positions(g: dict, elements: np.ndarray | None) -> tuple[list[Any], list[str]]:
    """Localised events in plan view (m, x east, y north) coloured by time with 1σ ellipses,
    and the hydrophones when the recording is at hand. Returns (layout rows, notes)."""
    from bokeh.models import ColumnDataSource, HoverTool
    from bokeh.transform import linear_cmap
    n = np.size(g["time"])
    idx = dec.stride(n, dec.POINTS_MAX)
    t = np.asarray(g["time"], float)[idx]
    x, y = np.asarray(g["x"], float)[idx], np.asarray(g["y"], float)[idx]
    z = np.asarray(g["z"], float)[idx]
    cov = np.asarray(g["cov"], float)[idx]
    e = [ellipse_params(c[:2, :2], 1.0) for c in cov] or [(0.0, 0.0, 0.0)]
    w, h, a = map(np.asarray, zip(*e))
    lo, hi = finite_range(t)
    src = ColumnDataSource({"x": x, "y": y, "z": z, "time": t, "w": w[:t.size],
                            "h": h[:t.size], "a": a[:t.size]}, name="positions_source")
    f = figure("positions", f"{n} localised events (1σ ellipses; colour: time, s)",
               "x east (m)", "y north (m)", height=560, width=700, match_aspect=True)
    colour = linear_cmap("time", "Plasma256", lo, hi)
    f.ellipse("x", "y", width="w", height="h", angle="a", source=src, fill_alpha=0.0,
              line_color=colour)
    r = f.scatter("x", "y", source=src, size=7, color=colour, legend_label="events")
    f.add_tools(HoverTool(renderers=[r], tooltips=[
        ("time", "@time{0.00} s"), ("x, y, z", "@x{0.0}, @y{0.0}, @z{0.0} m")]))
    if elements is not None:
        f.scatter(elements[:, 0], elements[:, 1], marker="triangle", size=10, color="black",
                  legend_label="hydrophones")
    f.legend.label_text_font_size = "8pt"
    return [f], [dec.note("Positions", dec.factor(n, dec.POINTS_MAX), "one kept")]
