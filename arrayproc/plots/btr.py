"""BTR plot: cone angle (or relative bearing) across, time running down, dB with a fixed
dynamic range."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from arrayproc.io.units import file_units, level_label
from arrayproc.plots import register_plot
from arrayproc.plots._passive import find_group, open_truth_recording, robust_top


@register_plot("btr")
def plot_btr(path: str, out_png: str, range_db: float = 20.0, beam: float | None = None,
             truth: bool = True) -> None:
    """Draw the first ``btr`` group of products file ``path`` into ``out_png``.

    The colour scale spans ``range_db`` dB below the 99.9th percentile of the record. When the
    recording named by the products' root attribute ``source`` holds ``/truth``, the true cone
    angles of the sources are drawn as dashed lines. ``beam`` is unused (LOFAR only).
    """
    import matplotlib.pyplot as plt

    g, root = find_group(path, "btr")
    t, cone, p = g["time"], g["cone_deg"], g["power_db"]
    elev = None
    if "elevation_deg" in g:  # 3-D beams: the bearings of the elevation nearest horizontal
        e = np.asarray(g["elevation_deg"], float)
        elev = float(e[np.argmin(np.abs(e))])
        sel = np.flatnonzero(e == elev)
        sel = sel[np.argsort(cone[sel])]
        cone, p = cone[sel], p[:, sel]
    top = robust_top(p)
    fig, ax = plt.subplots(figsize=(7.5, 8.0), dpi=110)
    if t.size:
        dt = np.median(np.diff(t)) if t.size > 1 else 1.0
        im = ax.imshow(p, aspect="auto", cmap="viridis", vmin=top - range_db, vmax=top,
                       extent=[cone[0], cone[-1], t[-1] + dt / 2, t[0] - dt / 2],
                       interpolation="nearest")
        cb = fig.colorbar(im, ax=ax, pad=0.02)
        cb.set_label(f"beam power Σ|Y|², {level_label(file_units(root), '²')}, unnormalised "
                     f"({range_db:g} dB range)")
    lr = str(g["attrs"].get("beam_mode", "cone")) == "lr"
    rec = open_truth_recording(root) if truth and elev is None else None
    if rec is not None:
        from arrayproc.io.truth import cone_angles, relative_bearings
        with rec:
            truth_fn = relative_bearings if lr else cone_angles
            for i, (name, c) in enumerate(truth_fn(rec, t).items()):
                ax.plot(c, t, ls=":", lw=1.2, alpha=0.8, color=f"C{(i + 1) % 10}",
                        label=f"truth: {name}")
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
    ax.set_title(f"BTR{band}\n{Path(path).name}", fontsize=10)
    fig.tight_layout()
    fig.savefig(out_png)
    plt.close(fig)
