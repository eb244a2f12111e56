"""Active section of the report: range-Doppler maps (one at a time, picked from a list) with
the true echoes, the contacts in range and cone angle coloured by SNR, and the contact list."""

from __future__ import annotations

from typing import Any

import numpy as np

from arrayproc.io.text import as_text
from arrayproc.plots.interactive import decimate as dec
from arrayproc.plots.interactive.common import colour_span, figure

#: Dynamic range of the range-Doppler maps, dB re each map's peak.
RD_RANGE_DB = 30.0
#: True echoes are drawn on a map when within this many degrees of its beam.
ECHO_GATE_DEG = 3.0

_PICK_MAP = """
const k = cb_obj.options.indexOf(cb_obj.value);
if (k < 0) { return; }
src.data = {image: [all.data["m" + k][0]]};
const a = axes.data;
img.glyph.x = a.x[k]; img.glyph.dw = a.dw[k]; img.glyph.y = a.y[k]; img.glyph.dh = a.dh[k];
fig.x_range.start = a.x[k]; fig.x_range.end = a.x[k] + a.dw[k];
fig.y_range.start = a.y[k]; fig.y_range.end = a.y[k] + a.dh[k];
const e = echoes_all.data, r = [], v = [], n = [];
for (let i = 0; i < e.map.length; i++) {
  if (e.map[i] === k) { r.push(e.range[i]); v.push(e.rate[i]); n.push(e.name[i]); }
}
echoes.data = {range: r, rate: v, name: n};
fig.title.text = cb_obj.value;
"""


def _echo_truth(rec):
    if rec is None:
        return None
    from arrayproc.io.truth import echo_truth
    return echo_truth(rec)


def range_doppler(g: dict, rec) -> tuple[list[Any], list[str]]:
    """The range-Doppler map of one (ping, beam) row at a time, with a list to pick the row;
    levels in dB re each map's peak. Returns (layout rows, notes)."""
    from bokeh.layouts import column
    from bokeh.models import ColumnDataSource, CustomJS, HoverTool, LinearColorMapper, Select
    from bokeh.palettes import Viridis256
    pings = np.asarray(g["ping"]).reshape(-1)
    cones = np.asarray(g["cone_deg"], float).reshape(-1)
    rows = dec.stride(pings.size, dec.RD_MAX_MAPS)
    notes = []
    if rows.size < pings.size:
        notes.append(f"Range-Doppler maps: {rows.size} of {pings.size} kept (even stride).")
    maps, ax, labels, k_all = {}, {"x": [], "dw": [], "y": [], "dh": []}, [], 1
    tr = _echo_truth(rec)
    echoes: dict[str, list] = {"map": [], "range": [], "rate": [], "name": []}
    for j, i in enumerate(rows):
        rng = np.asarray(g["range_m"][i] if np.ndim(g["range_m"]) == 2 else g["range_m"], float)
        rr = np.asarray(g["range_rate_mps"][i] if np.ndim(g["range_rate_mps"]) == 2
                        else g["range_rate_mps"], float)
        lev = np.asarray(g["level_db"][i], float)
        lev, kv = dec.block_max(lev, 0, dec.RD_MAX[0])
        lev, kr = dec.block_max(lev, 1, dec.RD_MAX[1])
        k_all = max(k_all, kv, kr)
        maps[f"m{j}"] = [(lev - np.nanmax(lev)).astype(np.float32)]
        drr = float(rr[1] - rr[0]) if rr.size > 1 else 1.0
        ax["x"].append(float(rng[0]))
        ax["dw"].append(float(rng[-1] - rng[0]))
        ax["y"].append(float(rr[0] - drr / 2))
        ax["dh"].append(float(rr[-1] - rr[0] + drr))
        labels.append(f"range-Doppler, ping {int(pings[i])}, cone {cones[i]:.1f} deg")
        if tr is not None:
            ra = tr["range_array_m"]
            m = ((tr["ping"] == pings[i]) & (ra >= rng.min()) & (ra <= rng.max())
                 & (np.abs(tr["cone_deg"] - cones[i]) < ECHO_GATE_DEG))
            for r, v, n in zip(ra[m], tr["range_rate_mps"][m], tr["name"][m]):
                echoes["map"].append(j)
                echoes["range"].append(float(r))
                echoes["rate"].append(float(v))
                echoes["name"].append(as_text(n))
    notes.append(dec.note("Range-Doppler cells", k_all, "maximum"))
    f = figure("range_doppler", labels[0], "range from the array (m)",
               "range rate (m/s, positive opening)", height=420, width=900,
               x_range=(ax["x"][0], ax["x"][0] + ax["dw"][0]),
               y_range=(ax["y"][0], ax["y"][0] + ax["dh"][0]))
    cmap = LinearColorMapper(palette=Viridis256, low=-RD_RANGE_DB, high=0.0)
    src = ColumnDataSource({"image": maps["m0"]}, name="range_doppler_source")
    img = f.image(image="image", source=src, x=ax["x"][0], y=ax["y"][0], dw=ax["dw"][0],
                  dh=ax["dh"][0], color_mapper=cmap, name="range_doppler_image")
    f.add_tools(HoverTool(renderers=[img], tooltips=[
        ("range", "$x{0} m"), ("range rate", "$y{0.00} m/s"), ("level", "@image{0.0} dB")]))
    from bokeh.models import ColorBar
    f.add_layout(ColorBar(color_mapper=cmap, title="|χ|², dB re peak", width=10), "right")
    first = [i for i, m in enumerate(echoes["map"]) if m == 0]
    shown = ColumnDataSource({k: [v[i] for i in first] for k, v in echoes.items() if k != "map"},
                             name="range_doppler_echoes")
    f.scatter("range", "rate", source=shown, size=16, fill_alpha=0.0, line_color="white",
              line_width=1.5, legend_label="true echo")
    f.legend.label_text_font_size = "8pt"
    pick = Select(title="ping and beam", value=labels[0], options=labels, width=420,
                  name="range_doppler_pick")
    pick.js_on_change("value", CustomJS(args={
        "src": src, "all": ColumnDataSource(maps, name="range_doppler_all"),
        "axes": ColumnDataSource(ax), "img": img, "fig": f, "echoes": shown,
        "echoes_all": ColumnDataSource(echoes)}, code=_PICK_MAP))
    return [column(pick, f)], notes


#: Columns of the contact list: (products column, heading, format).
CONTACT_COLUMNS = (("time", "time (s)", "0.00"), ("ping", "ping", "0"),
                   ("range_m", "range (m)", "0"), ("cone_deg", "cone (deg)", "0.0"),
                   ("bearing_port_deg", "bearing if port (deg)", "0.0"),
                   ("bearing_stbd_deg", "bearing if starboard (deg)", "0.0"),
                   ("range_rate_mps", "range rate (m/s)", "0.00"),
                   ("absolute_doppler_mps", "absolute Doppler (m/s)", "0.00"),
                   ("snr_db", "SNR (dB)", "0.0"))


def contacts(g: dict, rec) -> tuple[list[Any], list[str]]:
    """Contacts in range against cone angle coloured by SNR (the true echoes overlaid), and
    the list of the contacts with the highest SNR. Returns (layout rows, notes)."""
    from bokeh.models import (
        ColumnDataSource,
        DataTable,
        HoverTool,
        NumberFormatter,
        TableColumn,
    )
    from bokeh.transform import linear_cmap
    n = np.size(g["time"])
    snr = np.asarray(g["snr_db"], float)
    idx = dec.stride(n, dec.POINTS_MAX)
    notes = [dec.note("Contact points", dec.factor(n, dec.POINTS_MAX), "one kept")]
    pts = ColumnDataSource({"cone": np.asarray(g["cone_deg"], float)[idx],
                            "range": np.asarray(g["range_m"], float)[idx],
                            "snr": snr[idx], "ping": np.asarray(g["ping"])[idx],
                            "moving": np.asarray(g["moving"]).astype(int)[idx]},
                           name="contacts_source")
    lo, hi = colour_span(snr)
    f = figure("contacts", f"{n} CFAR contacts (colour: SNR, dB)", "cone angle (deg)",
               "range from the array (m)", height=420, width=900)
    r = f.scatter("cone", "range", source=pts, size=5,
                  color=linear_cmap("snr", "Viridis256", lo, hi))
    f.add_tools(HoverTool(renderers=[r], tooltips=[
        ("ping", "@ping"), ("cone", "@cone{0.0} deg"), ("range", "@range{0} m"),
        ("SNR", "@snr{0.0} dB"), ("moving", "@moving")]))
    tr = _echo_truth(rec)
    if tr is not None:
        f.scatter(tr["cone_deg"], tr["range_array_m"], marker="x", size=10, color="#d62728",
                  line_width=2, legend_label="true echoes")
        f.legend.label_text_font_size = "8pt"
    order = np.argsort(-snr, kind="stable")[:dec.TABLE_MAX]
    if order.size < n:
        notes.append(f"Contact list: the {order.size} of {n} with the highest SNR.")
    order = order[np.argsort(np.asarray(g["time"])[order], kind="stable")]
    table = {c: np.asarray(g[c], float)[order] for c, _, _ in CONTACT_COLUMNS if c in g}
    cols = [TableColumn(field=c, title=h, formatter=NumberFormatter(format=fmt))
            for c, h, fmt in CONTACT_COLUMNS if c in g]
    t = DataTable(source=ColumnDataSource(table, name="contact_list"), columns=cols,
                  width=1100, height=280, name="contact_table", index_position=None)
    return [f, t], notes
