"""Bearings plot (``plot --kind bearings``): each detection's two candidate true bearings
against time, port on the left and starboard on the right, coloured by SNR; time runs down
(sonar orientation); the truth sources' true bearings on the side they are on."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from arrayproc.plots import finish, register_plot, subplots, write_figure
from arrayproc.plots import limits as lim
from arrayproc.plots._passive import find_group, open_truth_recording, true_bearings

#: Figure size and panels of the bearings plot.
LAYOUT = {"figsize": (11.0, 7.0), "dpi": 110, "nrows": 1, "ncols": 2, "sharey": True,
          "layout": "constrained"}
#: Truth colours (dashed) that stand out against viridis points.
TRUTH_COLOURS = ("tab:red", "tab:orange", "magenta", "tab:brown")


@register_plot("bearings")
def plot_bearings(path: str, out_png: str, truth: bool = True, **_: Any) -> None:
    """Draw the first ``bearings`` group of products file ``path`` into ``out_png``
    (:func:`draw_bearings`), within the plot's time limits."""
    g, root = find_group(path, "bearings")
    g = lim.select(g, lim.rows(g["time"], what="bearings"), np.size(g["time"]))
    write_figure(lambda axes: draw_bearings(g, root, axes, truth=truth, file=Path(path).name),
                 out_png, LAYOUT)


def draw_bearings(g: dict, root: dict, axes: Any = None, truth: bool = True,
                  file: str = "") -> Any:
    """Draw a ``bearings`` group on two axes: port and starboard candidate bearings (deg
    true, clockwise from north) across, time down, coloured by SNR.

    Parameters
    ----------
    g : dict
        A ``bearings`` products group (``time``, ``bearing_port_deg``, ``bearing_stbd_deg``,
        ``snr_db``).
    root : dict
        The products file's root attributes (``source``: the recording with ``/truth``).
    axes : pair of matplotlib Axes, optional
        Where to draw (default: a new figure).
    truth : bool
        Draw the true bearings of the recording's truth sources on the side each is on.
    file : str
        The file name shown in the title.

    Returns
    -------
    matplotlib Figure
    """
    from arrayproc.geo.angles import wrap_180
    t = np.asarray(g["time"], float)
    snr = np.asarray(g["snr_db"], float)
    fin = snr[np.isfinite(snr)]
    lo, hi = (np.percentile(fin, [2, 98]) if fin.size else (0.0, 1.0))
    fig, (ap, asb), new = subplots(axes, LAYOUT)
    rec = open_truth_recording(root) if truth else None
    tt = np.linspace(t.min(), t.max(), 400) if t.size else np.zeros(0)
    if rec is not None and tt.size:
        with rec:
            tb = true_bearings(rec, tt)
            side = {k: np.sign(wrap_180(b - rec.nav.at(tt)[1])) for k, b in tb.items()}
    else:
        tb, side = {}, {}
    sc = None
    for ax, col, want, name, colour in ((ap, "bearing_port_deg", -1, "port", "tab:red"),
                                        (asb, "bearing_stbd_deg", 1, "starboard",
                                         "tab:green")):
        sc = ax.scatter(np.asarray(g[col], float) % 360.0, t, c=snr, s=9, cmap="viridis",
                        vmin=lo, vmax=max(hi, lo + 1.0), edgecolors="none")
        for i, (src, b) in enumerate(tb.items()):
            b = np.where(side[src] == want, b, np.nan)
            b = np.where(np.abs(np.diff(b, prepend=b[0])) > 180, np.nan, b)
            if np.isfinite(b).any():
                ax.plot(b, tt, ls="--", lw=1.2, color=TRUTH_COLOURS[i % len(TRUTH_COLOURS)],
                        label=f"truth: {src}")
        ax.set_xlim(0.0, 360.0)
        ax.set_xticks(np.arange(0, 361, 45))
        ax.set_xlabel("true bearing (deg, clockwise from north)")
        ax.set_title(f"{name} candidates", color=colour, fontsize=10)
        ax.grid(True, alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(loc="lower right", fontsize=8, framealpha=0.7)
    ap.set_ylabel("time (s since recording start)")
    if t.size:
        ap.set_ylim(t.max() + 0.5, t.min() - 0.5)  # time runs down (shared with starboard)
    if sc is not None:
        fig.colorbar(sc, ax=[ap, asb], pad=0.02, shrink=0.9).set_label("SNR over the TPSW "
                                                                        "background (dB)")
    fig.suptitle(f"bearings: {t.size} detections, port and starboard candidates\n{file}",
                 fontsize=10)
    return finish(fig, new, LAYOUT)
