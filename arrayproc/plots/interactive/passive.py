"""Passive section of the report: BTR with detections, tracks and truth; the LOFAR of the
beam under the cursor; the bearing-time plot.

The BTR and the LOFAR share their time axis (zooming one zooms the other). Moving the mouse
over the BTR shows the LOFAR of the beam under the cursor; a click pins that beam (the
"follow" toggle resumes following). The swap runs in the browser (Bokeh ``CustomJS``) over
the LOFAR beams the page keeps (:mod:`~arrayproc.plots.interactive.decimate`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from arrayproc.io.text import as_text
from arrayproc.io.units import file_units, level_label
from arrayproc.plots._passive import robust_top
from arrayproc.plots.interactive import decimate as dec
from arrayproc.plots.interactive.common import (
    PORT,
    STBD,
    TRUTH_COLOURS,
    colour_span,
    figure,
    finite_range,
    true_bearings,
)
from arrayproc.plots.lofar import TPSW_FLOOR_DB, TRUTH_GATE_DEG

#: Dynamic range of the BTR and LOFAR colour scales, dB.
RANGE_DB = 20.0
#: Width of the BTR and of the LOFAR beside it (px).
BTR_WIDTH, LOFAR_WIDTH, HEIGHT = 520, 580, 620

_PICK_BEAM = """
const x = cb_obj.x;
if (x == null || !isFinite(x)) { return; }
if (!tap && !follow.active) { return; }
if (tap) { follow.active = false; }

let best = 0, bd = Infinity;
for (let i = 0; i < cones.length; i++) {
  const d = Math.abs(cones[i] - x);
  if (d < bd) { bd = d; best = i; }
}
if (state.data.beam[0] === best && !tap) { return; }
img.data = {image: [all.data["b" + best][0]]};
state.data = {beam: [best], cone: [cones[best]]};
span.location = cones[best];
fig.title.text = "LOFAR, beam " + cones[best].toFixed(1) + " deg (" + label + ")";
const tr = truth_all.data;
const xs = [], ys = [], names = [];
for (let i = 0; i < tr.beam.length; i++) {
  if (tr.beam[i] === best) { xs.push(tr.xs[i]); ys.push(tr.ys[i]); names.push(tr.name[i]); }
}
truth.data = {xs: xs, ys: ys, name: names};
"""


def _beams(g: dict) -> tuple[np.ndarray, np.ndarray, str]:
    """Beam axis (ascending), the order that sorts it, and its label: cone angle, relative
    bearing (``beam_mode = "lr"``) or, for 3-D beams, the bearings of the elevation nearest
    horizontal."""
    cone = np.asarray(g["cone_deg"] if "cone_deg" in g else g["bearing_deg"], float)
    sel = np.arange(cone.size)
    if "elevation_deg" in g:
        e = np.asarray(g["elevation_deg"], float)
        sel = np.flatnonzero(e == e[np.argmin(np.abs(e))])
    order = sel[np.argsort(cone[sel], kind="stable")]
    if as_text(g["attrs"].get("beam_mode", "cone")) == "lr":
        label = "relative bearing (deg; 0 forward, + starboard, − port)"
    elif "elevation_deg" in g:
        label = "bearing relative to the array's forward axis (deg)"
    else:
        label = "cone angle (deg; 0 forward end-fire, 90 broadside)"
    return cone[order], order, label


def track_angles(tg: dict, rec) -> dict[int, dict[str, np.ndarray]]:
    """Per track id (confirmed rows when the file says): ``time``, ``cone`` (deg: the
    track's cone filter when it has one, else from the position and the recording's
    heading), ``bearing`` (deg true from ownship), ``side`` (+1 starboard, −1 port, 0
    unknown without a heading) and ``resolved`` (one side holds 90 % of the weight, so the
    position, hence the bearing, is that side's)."""
    from arrayproc.geo.angles import true_bearing, wrap_180
    t = np.asarray(tg["time"], float)
    ok = np.ones(t.size, bool)
    if "status" in tg and as_text(tg["attrs"].get("mode", "")) == "multi":
        ok = np.asarray(tg["status"]) == 1
    brg = np.degrees(true_bearing(np.asarray(tg["x"]) - np.asarray(tg["own_x"]),
                                  np.asarray(tg["y"]) - np.asarray(tg["own_y"])))
    hd = rec.nav.at(t)[1] if rec is not None and t.size else None
    rel = wrap_180(brg - hd) if hd is not None else None
    if "cone_deg" in tg:
        cone = np.asarray(tg["cone_deg"], float)
    elif rel is not None:
        cone = np.abs(rel)
    else:
        cone = np.full(t.size, np.nan)
    side = np.sign(rel) if rel is not None else np.zeros(t.size)
    resolved = np.ones(t.size, bool)
    if "side_weight" in tg:  # before one side holds 90 %, the position is the mirrors' mean
        sw = np.asarray(tg["side_weight"], float)
        resolved = ~np.isfinite(sw) | (np.abs(sw - 0.5) >= 0.4)
    out = {}
    for tid in np.unique(np.asarray(tg["track_id"])):
        m = np.flatnonzero((np.asarray(tg["track_id"]) == tid) & ok)
        m = m[np.argsort(t[m], kind="stable")]
        if m.size:
            out[int(tid)] = {"time": t[m], "cone": cone[m], "bearing": brg[m], "side": side[m],
                             "resolved": resolved[m]}
    return out


def btr_lofar(btr: dict | None, lofar: dict | None, bearings: dict | None,
              tracks: list[dict], root: dict, rec) -> tuple[list[Any], list[str]]:
    """The BTR (with bearing detections, tracks and truth overlaid) and, beside it, the
    LOFAR of the beam under the cursor. Returns (layout rows, decimation notes)."""
    from bokeh.layouts import row
    from bokeh.models import HoverTool, LinearColorMapper
    from bokeh.palettes import Viridis256
    units = file_units(root)
    notes: list[str] = []
    g = btr if btr is not None else lofar
    t = np.asarray(g["time"], float)
    cone, order, xlabel = _beams(g)
    if btr is not None:
        p = np.asarray(btr["power_db"], float)[:, order]
        what = "BTR, broadband beam power over the band"
    else:  # no BTR: the LOFAR's band power per beam stands in
        pl = np.asarray(lofar["power_db"], float)[:, order, :]
        p = 10 * np.log10(np.nanmean(10 ** (pl / 10), axis=2))
        what = "LOFAR power summed over its band (no BTR product)"
    p, kt = dec.block_mean_db(p, 0, dec.BTR_MAX[0])
    p, kb = dec.block_mean_db(p, 1, dec.BTR_MAX[1])
    tb, cb = dec.block_centres(t, kt), dec.block_centres(cone, kb)
    notes += [dec.note("BTR rows", kt, "power mean"), dec.note("BTR beams", kb, "power mean")]
    dt = float(np.median(np.diff(tb))) if tb.size > 1 else 1.0
    dc = float(np.median(np.diff(cb))) if cb.size > 1 else 1.0
    t0, t1 = float(tb[0] - dt / 2), float(tb[-1] + dt / 2)
    top = robust_top(p)
    fb = figure("btr", f"{what} ({RANGE_DB:g} dB range)", xlabel,
                "time (s since recording start)", height=HEIGHT, width=BTR_WIDTH,
                time_down=(t0, t1), x_range=(float(cb[0] - dc / 2), float(cb[-1] + dc / 2)))
    cmap = LinearColorMapper(palette=Viridis256, low=top - RANGE_DB, high=top)
    img = fb.image(image=[p.astype(np.float32)], x=float(cb[0] - dc / 2), y=t0,
                   dw=float(cb[-1] - cb[0] + dc), dh=t1 - t0, color_mapper=cmap,
                   name="btr_image")
    img.data_source.name = "btr_source"
    fb.add_tools(HoverTool(renderers=[img], tooltips=[
        ("beam", "$x{0.0} deg"), ("time", "$y{0.0} s"),
        ("level", f"@image{{0.0}} {level_label(units, '²')}")]))
    fb.add_layout(_colourbar(cmap, f"Σ|Y|², {level_label(units, '²')}"), "right")
    _overlay_btr(fb, bearings, tracks, root, rec, t, notes)
    if lofar is None:
        return [fb], notes
    fl, extra = _lofar(lofar, fb, root, rec, units)
    notes += extra
    return [row(fb, fl)], notes


def _colourbar(cmap, title: str):
    from bokeh.models import ColorBar
    return ColorBar(color_mapper=cmap, title=title, width=10, title_text_font_size="9pt")


def _overlay_btr(fb, bearings, tracks, root, rec, t, notes) -> None:
    """Bearing detections (cone, time), tracks (cone from the track) and truth on the BTR."""
    from bokeh.models import ColumnDataSource, HoverTool
    from bokeh.palettes import Category10_10
    if bearings is not None and np.size(bearings["time"]):
        n = np.size(bearings["time"])
        idx = dec.stride(n, dec.POINTS_MAX)
        notes.append(dec.note("Detections", dec.factor(n, dec.POINTS_MAX), "one kept"))
        src = ColumnDataSource({"cone": np.asarray(bearings["cone_deg"], float)[idx],
                                "time": np.asarray(bearings["time"], float)[idx],
                                "snr": np.asarray(bearings["snr_db"], float)[idx]},
                               name="btr_detections")
        r = fb.scatter("cone", "time", source=src, size=5, marker="circle", fill_alpha=0.0,
                       line_color="white", line_width=1.2, legend_label="bearing detections")
        fb.add_tools(HoverTool(renderers=[r], tooltips=[
            ("cone", "@cone{0.0} deg"), ("time", "@time{0.0} s"), ("SNR", "@snr{0.0} dB")]))
    for tg in tracks:
        for tid, a in track_angles(tg, rec).items():
            if np.all(np.isnan(a["cone"])):
                continue
            fb.line(a["cone"], a["time"], line_width=2.5,
                    color=Category10_10[(tid + 1) % 10], legend_label=f"track {tid}")
    if rec is not None:
        from arrayproc.io.truth import cone_angles
        for i, (name, c) in enumerate(cone_angles(rec, t).items()):
            fb.line(c, t, line_dash="dashed", line_width=1.5,
                    color=TRUTH_COLOURS[i % len(TRUTH_COLOURS)], legend_label=f"truth {name}")
    if fb.legend:
        fb.legend.location = "bottom_left"
        fb.legend.click_policy = "hide"
        fb.legend.label_text_font_size = "8pt"
        fb.legend.background_fill_alpha = 0.6


def _lofar(g: dict, fb, root: dict, rec, units: str):
    """The LOFAR figure of the beam with the highest mean level, and the data and callbacks
    that swap in the beam under the BTR's cursor."""
    from bokeh import events
    from bokeh.models import (
        ColumnDataSource,
        CustomJS,
        HoverTool,
        LinearColorMapper,
        Span,
        Toggle,
    )
    from bokeh.palettes import Viridis256
    notes: list[str] = []
    t = np.asarray(g["time"], float)
    f = np.asarray(g["freq"], float)
    cone, order, _ = _beams(g)
    p = np.asarray(g["power_db"], np.float32)[:, order, :]
    p, kt = dec.block_mean_db(p, 0, dec.LOFAR_MAX_ROWS)
    p, kf = dec.block_max(p, 2, dec.LOFAR_MAX_BINS)
    tl, fl = dec.block_centres(t, kt), dec.block_centres(f, kf)
    per_beam = p.shape[0] * p.shape[2]
    keep = dec.stride(cone.size, max(1, dec.LOFAR_MAX_VALUES // max(1, per_beam)))
    notes += [dec.note("LOFAR rows", kt, "power mean"),
              dec.note("LOFAR bins", kf, "maximum (keeps one-bin tonals)")]
    if keep.size < cone.size:
        notes.append(f"LOFAR beams: every {dec.factor(cone.size, keep.size)}th of "
                     f"{cone.size} kept ({keep.size}); the cursor picks the nearest kept beam.")
    cones = cone[keep]
    mean = np.nanmean(p[:, keep, :], axis=(0, 2))
    b0 = int(np.nanargmax(mean)) if np.isfinite(mean).any() else 0
    tpsw = as_text(g["attrs"].get("normalise", "none")) == "tpsw"
    top = TPSW_FLOOR_DB + RANGE_DB if tpsw else robust_top(p)
    cmap = LinearColorMapper(palette=Viridis256, low=top - RANGE_DB, high=top)
    dt = float(np.median(np.diff(tl))) if tl.size > 1 else 1.0
    df = float(np.median(np.diff(fl))) if fl.size > 1 else 1.0
    lab = "level over TPSW background, dB" if tpsw else f"Σ|Y|², {level_label(units, '²')}"
    fig = figure("lofar", f"LOFAR, beam {cones[b0]:.1f} deg ({lab})", "frequency (Hz)",
                 "time (s since recording start)", height=HEIGHT, width=LOFAR_WIDTH,
                 x_range=(float(fl[0] - df / 2), float(fl[-1] + df / 2)))
    fig.y_range = fb.y_range
    beams = {f"b{i}": [p[:, j, :].astype(np.float32)] for i, j in enumerate(keep)}
    all_src = ColumnDataSource(beams, name="lofar_all")
    src = ColumnDataSource({"image": beams[f"b{b0}"]}, name="lofar_source")
    y0 = float(tl[0] - dt / 2)
    img = fig.image(image="image", source=src, x=float(fl[0] - df / 2), y=y0,
                    dw=float(fl[-1] - fl[0] + df), dh=float(tl[-1] - tl[0] + dt),
                    color_mapper=cmap, name="lofar_image")
    fig.add_tools(HoverTool(renderers=[img], tooltips=[
        ("frequency", "$x{0.0} Hz"), ("time", "$y{0.0} s"), ("level", "@image{0.0} dB")]))
    fig.add_layout(_colourbar(cmap, lab), "right")
    truth_all = _lofar_truth(rec, t, cones)
    first = [i for i, b in enumerate(truth_all["beam"]) if b == b0]
    truth = ColumnDataSource({k: [v[i] for i in first] for k, v in truth_all.items()
                              if k != "beam"}, name="lofar_truth")
    fig.multi_line("xs", "ys", source=truth, line_dash="dotted", line_width=1.5,
                   color="#ff7f0e", line_alpha=0.8)
    truth_all = ColumnDataSource(truth_all, name="lofar_truth_all")
    state = ColumnDataSource({"beam": [b0], "cone": [float(cones[b0])]},
                             name="lofar_state")
    span = Span(location=float(cones[b0]), dimension="height", line_color="white",
                line_dash="dashed", line_width=1.5, name="btr_beam_marker")
    fb.add_layout(span)
    follow = Toggle(label="LOFAR follows the cursor (a click on the BTR pins the beam)",
                    active=True, name="lofar_follow", width=420)
    args = {"img": src, "all": all_src, "state": state, "span": span, "fig": fig,
            "follow": follow, "truth": truth, "truth_all": truth_all, "label": lab,
            "cones": [float(c) for c in cones]}
    fb.js_on_event(events.MouseMove, CustomJS(args={**args, "tap": False}, code=_PICK_BEAM))
    fb.js_on_event(events.Tap, CustomJS(args={**args, "tap": True}, code=_PICK_BEAM))
    from bokeh.layouts import column
    return column(follow, fig), notes


def _lofar_truth(rec, t: np.ndarray, cones: np.ndarray) -> dict[str, list]:
    """Truth tonals for each kept LOFAR beam: one row per (beam, source, tonal) with the
    Doppler-shifted frequency where the source lies within TRUTH_GATE_DEG of the beam (NaN
    elsewhere, which breaks the line)."""
    out: dict[str, list] = {"beam": [], "xs": [], "ys": [], "name": []}
    if rec is None:
        return out
    from arrayproc.io.truth import cone_angles, tonal_frequencies
    ca = cone_angles(rec, t)
    for name, fr in tonal_frequencies(rec, t).items():
        for b, c in enumerate(cones):
            near = np.abs(ca[name] - c) <= TRUTH_GATE_DEG
            if not near.any():
                continue
            for k in range(fr.shape[1]):
                out["beam"].append(b)
                out["xs"].append(np.where(near, fr[:, k], np.nan))
                out["ys"].append(t)
                out["name"].append(name)
    return out


def bearing_time(bearings: dict, tracks: list[dict], rec) -> tuple[list[Any], list[str]]:
    """Bearing against time (true bearing across, time running down), one panel for the
    port and one for the starboard candidate of each detection, coloured by SNR; tracks on
    the side they resolved to; the true bearings of the truth sources."""
    from bokeh.layouts import row
    from bokeh.models import ColumnDataSource, HoverTool
    from bokeh.palettes import Category10_10
    from bokeh.transform import linear_cmap
    t = np.asarray(bearings["time"], float)
    n = t.size
    idx = dec.stride(n, dec.POINTS_MAX)
    notes = [dec.note("Bearing points", dec.factor(n, dec.POINTS_MAX), "one kept")]
    snr = np.asarray(bearings["snr_db"], float)
    lo, hi = colour_span(snr)
    t0, t1 = finite_range(t, pad=1.0)
    tt = np.linspace(t0, t1, 400)
    truth = true_bearings(rec, tt) if rec is not None else {}
    if truth:
        from arrayproc.geo.angles import wrap_180
        hd = rec.nav.at(tt)[1]
        truth_side = {k: np.sign(wrap_180(b - hd)) for k, b in truth.items()}
    ang = track_angles(tracks[0], rec) if tracks else {}
    figs = []
    for side, col, colour in (("port", "bearing_port_deg", PORT),
                              ("starboard", "bearing_stbd_deg", STBD)):
        f = figure(f"bearings_{side}", f"{side} candidate bearings (colour: SNR, dB)",
                   "true bearing (deg, clockwise from north)",
                   "time (s since recording start)", height=520, width=550,
                   time_down=(t0, t1), x_range=(0.0, 360.0))
        f.title.text_color = colour
        src = ColumnDataSource({"bearing": np.asarray(bearings[col], float)[idx] % 360.0,
                                "time": t[idx], "snr": snr[idx],
                                "cone": np.asarray(bearings["cone_deg"], float)[idx]},
                               name=f"bearings_{side}_source")
        r = f.scatter("bearing", "time", source=src, size=4,
                      color=linear_cmap("snr", "Viridis256", lo, hi))
        f.add_tools(HoverTool(renderers=[r], tooltips=[
            ("bearing", "@bearing{0.0} deg"), ("cone", "@cone{0.0} deg"),
            ("time", "@time{0.0} s"), ("SNR", "@snr{0.0} dB")]))
        want = -1 if side == "port" else 1
        for i, (name, b) in enumerate(truth.items()):
            b = np.where(truth_side[name] == want, b, np.nan)
            if np.all(np.isnan(b)):
                continue
            f.line(np.where(np.abs(np.diff(b, prepend=b[0])) > 180, np.nan, b), tt,
                   line_dash="dashed", color=TRUTH_COLOURS[i % len(TRUTH_COLOURS)],
                   legend_label=f"truth {name}")
        for tid, a in ang.items():
            m = a["resolved"] & ((a["side"] == want) | (a["side"] == 0))
            if m.any():
                b = np.where(m, a["bearing"], np.nan)
                f.line(b, a["time"], line_width=2.5, color=Category10_10[(tid + 1) % 10],
                       legend_label=f"track {tid}")
        if f.legend:
            f.legend.click_policy = "hide"
            f.legend.label_text_font_size = "8pt"
        figs.append(f)
    figs[1].y_range = figs[0].y_range
    return [row(*figs)], notes

