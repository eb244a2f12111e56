"""``--kind metrics``: GOSPA and OSPA of a multi-target tracks file against the simulator's
truth over time, and how long each source was held by one track
(:func:`arrayproc.evaluate.metrics.evaluate_tracks_file`)."""

from __future__ import annotations

import os
from typing import Any

import numpy as np

from arrayproc.plots import finish, register_plot, subplots, write_figure

#: Figure size and panels of the metrics plot.
LAYOUT = {"figsize": (8, 7), "nrows": 2, "ncols": 1, "gridspec_kw": {"height_ratios": [3, 2]}}


@register_plot("metrics")
def plot_metrics(tracks_path: str, out_png: str, c: float = 1000.0, p: float = 2.0,
                 **_: Any) -> None:
    """GOSPA (c = ``c`` m, order ``p``, α = 2) with its localisation / missed / false parts
    and OSPA against time (min), and per source the held fraction, breaks and final position
    error (:func:`draw_metrics`)."""
    from arrayproc.evaluate.metrics import evaluate_tracks_file

    r = evaluate_tracks_file(tracks_path, c=c, p=p)
    write_figure(lambda axes: draw_metrics(r, axes, c=c, p=p,
                                           file=os.path.basename(tracks_path)),
                 out_png, LAYOUT, dpi=120)


def draw_metrics(r: dict, axes: Any = None, c: float = 1000.0, p: float = 2.0,
                 file: str = "") -> Any:
    """Draw the metrics of :func:`arrayproc.evaluate.metrics.evaluate_tracks_file` (``r``,
    computed with ``c`` and ``p``) on two axes (default: a new figure); ``file`` the tracks
    file in the title. Returns the matplotlib Figure."""
    t = r["times"] / 60.0
    fig, (a1, a2), new = subplots(axes, LAYOUT)
    a1.plot(t, r["gospa"], "k-", lw=1.8, label=f"GOSPA (c = {c:g} m, p = {p:g}, α = 2)")
    a1.plot(t, r["ospa"], "--", color="tab:gray", lw=1.2, label="OSPA")
    for key, col, lab in (("gospa_localisation", "tab:blue", "localisation"),
                          ("gospa_missed", "tab:orange", "missed"),
                          ("gospa_false", "tab:red", "false")):
        a1.plot(t, np.asarray(r[key]) ** (1.0 / p), color=col, lw=1, label=f"{lab} part "
                "(its p-th root)")
    a1.set_xlabel("time (min)")
    a1.set_ylabel("distance (m)")
    a1.set_ylim(0, 1.05 * max(c * 2 ** (-1 / p) * np.sqrt(len(r["sources"]) * 2),
                              float(np.max(r["gospa"], initial=0.0))))
    a1.grid(alpha=0.3)
    a1.legend(fontsize=8, loc="upper right")
    names = r["sources"]
    x = np.arange(len(names))
    a2.bar(x, 100 * np.asarray(r["held"]), color="tab:green", alpha=0.8)
    a2.axhline(80, color="k", ls=":", lw=1)
    for i in range(len(names)):
        fe = r["final_error_m"][i]
        a2.text(x[i], 3, f"track {r['principal'][i]}\nbreaks {r['breaks'][i]}\n"
                f"final {fe:.0f} m" if np.isfinite(fe) else "no track", ha="center",
                va="bottom", fontsize=8)
    a2.set_xticks(x, names)
    a2.set_ylabel("held by one track (%)")
    a2.set_ylim(0, 105)
    a2.set_title(f"{r['n_confirmed']} confirmed tracks, {len(r['false_tracks'])} false",
                 fontsize=9)
    a1.set_title(f"{file}: multi-target metrics against truth")
    return finish(fig, new, LAYOUT)
