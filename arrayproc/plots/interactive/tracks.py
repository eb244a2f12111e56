"""Track map of the report: plan view (km, x east, y north) of the ownship, each track with
its 2σ position ellipses, the truth, and the batch TMA solutions with their 2σ Cramér-Rao
ellipses at the start of their windows (thesis eq. (3.53))."""

from __future__ import annotations

from typing import Any

import numpy as np

from arrayproc.io.text import as_text
from arrayproc.plots.interactive import decimate as dec
from arrayproc.plots.interactive.common import TRUTH_COLOURS, figure

#: Position ellipses: n σ, and about this many per track.
N_SIGMA, ELLIPSES_PER_TRACK = 2.0, 8


def ellipse_params(cov2: np.ndarray, n_sigma: float = N_SIGMA) -> tuple[float, float, float]:
    """(width, height, angle) of the ``n_sigma`` ellipse of a 2×2 covariance, for Bokeh's
    ``ellipse`` glyph: the full axes, 2·n_sigma·√λ of the eigenvalues λ (in the square root
    of the covariance's unit), and the angle (rad, counter-clockwise from the x axis) of the
    width axis, the major one."""
    w, v = np.linalg.eigh(0.5 * (cov2 + cov2.T))
    w = np.clip(w, 0.0, None)
    return (2 * n_sigma * float(np.sqrt(w[1])), 2 * n_sigma * float(np.sqrt(w[0])),
            float(np.arctan2(v[1, 1], v[0, 1])))


def _shown_rows(g: dict) -> dict[int, np.ndarray]:
    """Rows of each track to draw, as the track plot draws them (confirmed rows of a
    multi-target file once one side holds 90 %; a single-target file from its first
    update)."""
    t = np.asarray(g["time"], float)
    multi = as_text(g["attrs"].get("mode", "")) == "multi"
    out = {}
    for tid in np.unique(np.asarray(g["track_id"])):
        m = np.flatnonzero(np.asarray(g["track_id"]) == tid)
        m = m[np.argsort(t[m], kind="stable")]
        if multi and "status" in g:
            m = m[np.asarray(g["status"])[m] == 1]
        elif m.size > 1:
            m = m[1:]
        if multi and "side_weight" in g:
            sw = np.asarray(g["side_weight"], float)[m]
            m = m[~np.isfinite(sw) | (np.abs(sw - 0.5) >= 0.4)]
        if m.size:
            out[int(tid)] = m[dec.stride(m.size, dec.POINTS_MAX)]
    return out


def track_map(tracks: list[dict], tmas: list[dict], rec) -> tuple[list[Any], list[str]]:
    """The track map figure. Returns (layout rows, notes)."""
    from bokeh.models import ColumnDataSource, HoverTool
    from bokeh.palettes import Category10_10
    f = figure("track_map", "track map (2σ ellipses; TMA: 2σ CRLB at the window start)",
               "x east (km)", "y north (km)", height=650, width=900, match_aspect=True)
    spans = []
    for g in tracks:
        t = np.asarray(g["time"], float)
        if t.size:
            spans.append((t.min(), t.max()))
        if "own_x" in g and t.size:
            o = np.argsort(t, kind="stable")
            f.line(np.asarray(g["own_x"])[o] / 1e3, np.asarray(g["own_y"])[o] / 1e3,
                   color="black", line_width=2, legend_label="ownship")
        for tid, m in _shown_rows(g).items():
            c = Category10_10[(tid + 1) % 10]
            src = ColumnDataSource({"x": np.asarray(g["x"])[m] / 1e3,
                                    "y": np.asarray(g["y"])[m] / 1e3, "time": t[m],
                                    "id": np.full(m.size, tid)}, name=f"track_{tid}")
            f.line("x", "y", source=src, color=c, line_width=2, legend_label=f"track {tid}")
            r = f.scatter("x", "y", source=src, color=c, size=3)
            f.add_tools(HoverTool(renderers=[r], tooltips=[
                ("track", "@id"), ("time", "@time{0.0} s"), ("x, y", "@x{0.00}, @y{0.00} km")]))
            cov = np.asarray(g["cov"])[m]
            every = max(1, m.size // ELLIPSES_PER_TRACK)
            e = [ellipse_params(cov[i, :2, :2] / 1e6) for i in range(every // 2, m.size, every)]
            if e:
                w, h, a = map(np.asarray, zip(*e))
                sel = np.arange(every // 2, m.size, every)
                f.ellipse(np.asarray(g["x"])[m][sel] / 1e3, np.asarray(g["y"])[m][sel] / 1e3,
                          width=w, height=h, angle=a, fill_alpha=0.0, line_color=c,
                          line_alpha=0.7)
    for i, g in enumerate(tmas):
        _tma(f, g, i)
    if rec is not None:
        from arrayproc.io.truth import sources
        lo, hi = (min(s[0] for s in spans), max(s[1] for s in spans)) if spans else (-1e30, 1e30)
        for i, (name, s) in enumerate(sources(rec).items()):
            tt = np.asarray(s["time"], float)
            keep = (tt >= lo) & (tt <= hi)
            p = np.asarray(s["position"], float)[keep if keep.any() else slice(None)]
            f.line(p[:, 0] / 1e3, p[:, 1] / 1e3, line_dash="dashed", line_width=2,
                   color=TRUTH_COLOURS[i % len(TRUTH_COLOURS)], legend_label=f"truth {name}")
        if not tracks:
            t = np.linspace(min(np.min(g["t0"]) for g in tmas),
                            max(np.max(g["t1"]) for g in tmas), 300)
            own = rec.nav.at(t)[0]
            f.line(own[:, 0] / 1e3, own[:, 1] / 1e3, color="black", line_width=2,
                   legend_label="ownship")
    f.legend.click_policy = "hide"
    f.legend.label_text_font_size = "8pt"
    return [f], []


def _tma(f, g: dict, i: int) -> None:
    """One ``tma`` group on the map: each solution's constant-velocity track over its window
    and its 2σ CRLB ellipse at the window start."""
    from bokeh.models import ColumnDataSource, HoverTool
    n = np.size(g["x"])
    for j in range(n):
        st = np.array([g["x"][j], g["y"][j], g["vx"][j], g["vy"][j]], float)
        tau = np.linspace(0.0, float(g["t1"][j] - g["t0"][j]), 50)
        tr = st[None, :2] + tau[:, None] * st[None, 2:]
        f.line(tr[:, 0] / 1e3, tr[:, 1] / 1e3, color="#9467bd", line_width=3,
               legend_label="TMA solution")
        src = ColumnDataSource({"x": [st[0] / 1e3], "y": [st[1] / 1e3],
                                "t0": [float(g["t0"][j])], "course": [float(g["heading_deg"][j])],
                                "speed": [float(g["speed_mps"][j])]}, name=f"tma_{i}_{j}")
        r = f.scatter("x", "y", source=src, color="#9467bd", size=8, marker="square")
        f.add_tools(HoverTool(renderers=[r], tooltips=[
            ("TMA at", "@t0{0.0} s"), ("course", "@course{0.0} deg"),
            ("speed", "@speed{0.00} m/s")]))
        c = np.asarray(g["crlb"][j], float)[:2, :2]
        if np.all(np.isfinite(c)):
            w, h, a = ellipse_params(c / 1e6)
            f.ellipse([st[0] / 1e3], [st[1] / 1e3], width=w, height=h, angle=a,
                      fill_alpha=0.0, line_color="#9467bd", line_width=2,
                      legend_label="TMA 2σ CRLB")
