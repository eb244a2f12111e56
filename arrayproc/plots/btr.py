"""BTR plot: cone angle (or relative bearing) across, time running down, dB with a fixed
dynamic range."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from arrayproc.io.units import file_units, level_label
from arrayproc.plots import finish, register_plot, subplots, write_figure
from arrayproc.plots._passive import find_group, open_truth_recording, robust_top

#: Figure size and resolution of the BTR plot.
LAYOUT = {"figsize": (7.5, 8.0), "dpi": 110}


@register_plot("btr")
def plot_btr(path: str, out_png: str, range_db: float = 20.0, beam: float | None = None,
             truth: bool = True, detections: bool = True) -> None:
    """Draw the first ``btr`` group of products file ``path`` into ``out_png``
    (:func:`draw_btr`) within the plot's time limits, with the rows of the file's first
    ``bearings`` group overlaid when ``detections``. ``beam`` is unused (LOFAR only)."""
    from arrayproc.io.products import read_products
    from arrayproc.plots import limits as lim
    prod = read_products(path)
    g, root = find_group(path, "btr", prod)
    g = lim.select(g, lim.rows(g["time"], what="btr"), np.size(g["time"]))
    det = next((b for b in prod.groups("bearings").values() if np.size(b.get("time", []))),
               None) if detections else None
    write_figure(lambda ax: draw_btr(g, root, ax, range_db=range_db, truth=truth,
                                     file=Path(path).name, detections=det), out_png, LAYOUT)


def draw_btr(g: dict, root: dict, ax: Any = None, range_db: float = 20.0, truth: bool = True,
             file: str = "", detections: dict | None = None) -> Any:
    """Draw a BTR: cone angle across, time running down.

    Parameters
    ----------
    g : dict
        A ``btr`` products group (``time``, ``cone_deg``, ``power_db``, optional
        ``elevation_deg``, ``attrs``), as :func:`arrayproc.io.products.read_products` gives.
    root : dict
        The products file's root attributes (``units``; ``source``, whose ``/truth`` is drawn).
    ax : matplotlib Axes, optional
        Where to draw (default: a new figure).
    range_db : float
        The colour scale spans this many dB below the 99.9th percentile of the record.
    truth : bool
        When the recording named by ``source`` holds ``/truth``, draw the true cone angles of
        the sources as dotted lines.
    file : str
        The file name shown under the title.
    detections : dict, optional
        A ``bearings`` products group: each detection's cone angle drawn at its time, as a
        hollow white circle (rows outside the BTR's time span are left out).

    Returns
    -------
    matplotlib Figure
    """
    t, cone, p = g["time"], g["cone_deg"], g["power_db"]
    elev = None
    if "elevation_deg" in g:  # 3-D beams: the bearings of the elevation nearest horizontal
        e = np.asarray(g["elevation_deg"], float)
        elev = float(e[np.argmin(np.abs(e))])
        sel = np.flatnonzero(e == elev)
        sel = sel[np.argsort(cone[sel])]
        cone, p = cone[sel], p[:, sel]
    top = robust_top(p)
    fig, ax, new = subplots(ax, LAYOUT)
    if t.size:
        dt = np.median(np.diff(t)) if t.size > 1 else 1.0
        im = ax.imshow(p, aspect="auto", cmap="viridis", vmin=top - range_db, vmax=top,
                       extent=[cone[0], cone[-1], t[-1] + dt / 2, t[0] - dt / 2],
                       interpolation="nearest")
        cb = fig.colorbar(im, ax=ax, pad=0.02)
        cb.set_label(f"beam power Σ|Y|², {level_label(file_units(root), '²')}, unnormalised "
                     f"({range_db:g} dB range)")
    lr = str(g["attrs"].get("beam_mode", "cone")) == "lr"
    if detections is not None and elev is None and t.size:
        dt_, dc_ = np.asarray(detections["time"], float), _detection_axis(detections, lr)
        m = (dt_ >= t.min()) & (dt_ <= t.max())
        ax.scatter(dc_[m], dt_[m], s=14, facecolors="none", edgecolors="white",
                   linewidths=0.8, label=f"bearing detections ({int(m.sum())})")
    rec = open_truth_recording(root) if truth and elev is None else None
    if rec is not None:
        from arrayproc.io.truth import cone_angles, relative_bearings
        with rec:
            truth_fn = relative_bearings if lr else cone_angles
            for i, (name, c) in enumerate(truth_fn(rec, t).items()):
                ax.plot(c, t, ls=":", lw=1.2, alpha=0.8, color=f"C{(i + 1) % 10}",
                        label=f"truth: {name}")
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="lower right", fontsize=8, framealpha=0.7)
    ax.set_xlim(min(cone[0], cone[-1]), max(cone[0], cone[-1]))
    ax.set_ylim(t[-1] if t.size else 1, t[0] if t.size else 0)
    if lr:
        ax.set_xlabel("relative bearing (deg; 0 = forward, + starboard, − port)")
    elif elev is None:
        ax.set_xlabel("cone angle (deg; 0 = forward end-fire, 90 = broadside)")
    else:
        ax.set_xlabel(f"bearing relative to the array's forward axis (deg), elevation {elev:g} deg")
    ax.set_ylabel("time (s since recording start)")
    lo, hi = g["attrs"].get("freq_lo"), g["attrs"].get("freq_hi")
    band = f", {lo:g}-{hi:g} Hz" if lo is not None else ""
    ax.set_title(f"BTR{band}\n{file}", fontsize=10)
    return finish(fig, new, LAYOUT)


def _detection_axis(b: dict, lr: bool) -> np.ndarray:
    """The BTR-axis angle of each detection: its relative bearing on relative-bearing beams
    (when the group has one), else its cone angle."""
    if lr and "rel_bearing_deg" in b:
        return np.asarray(b["rel_bearing_deg"], float)
    return np.asarray(b["cone_deg"], float)
