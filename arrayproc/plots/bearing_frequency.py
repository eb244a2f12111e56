"""Bearing-frequency display (``plot --kind bearing_frequency``): the LOFAR product's level
averaged over a time window, beam (cone angle) across and frequency up, so that each
tonal shows at its bearing; the truth sources' tonals at their cone angles."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from arrayproc.io.text import as_text
from arrayproc.io.units import file_units, level_label
from arrayproc.plots import finish, register_plot, subplots, write_figure
from arrayproc.plots import limits as lim
from arrayproc.plots._passive import find_group, open_truth_recording, robust_top
from arrayproc.plots.lofar import OVERLAY_COLOURS, TPSW_FLOOR_DB

#: Figure size and resolution of the bearing-frequency display.
LAYOUT = {"figsize": (8.5, 7.0), "dpi": 110}


@register_plot("bearing_frequency")
def plot_bearing_frequency(path: str, out_png: str, range_db: float = 20.0,
                           truth: bool = True, **_: Any) -> None:
    """Draw the first ``lofar`` group of ``path`` as a bearing-frequency display averaged
    over the plot's time limits (default: the whole record), within its band limits
    (:func:`draw_bearing_frequency`)."""
    g, root = find_group(path, "lofar")
    g = lim.select(g, lim.rows(g["time"], what="bearing_frequency"), np.size(g["time"]))
    keep = lim.bins(g["freq"], what="bearing_frequency")
    g = {**g, "freq": np.asarray(g["freq"])[keep],
         "power_db": np.asarray(g["power_db"])[:, :, keep]}
    write_figure(lambda ax: draw_bearing_frequency(g, root, ax, range_db=range_db,
                                                   truth=truth, file=Path(path).name),
                 out_png, LAYOUT)


def draw_bearing_frequency(g: dict, root: dict, ax: Any = None, range_db: float = 20.0,
                           truth: bool = True, file: str = "") -> Any:
    """Draw the mean power of a ``lofar`` group over its rows, cone angle across and
    frequency up.

    The mean is taken in linear power, 10·log10(mean(10^(L/10))), over the rows given.

    Parameters
    ----------
    g : dict
        A ``lofar`` products group (``time``, ``freq``, ``cone_deg``, ``power_db`` (n, beams,
        bins), ``attrs``).
    root : dict
        The products file's root attributes (``units``; ``source`` for the truth).
    ax : matplotlib Axes, optional
        Where to draw (default: a new figure).
    range_db : float
        Colour span, dB (from TPSW_FLOOR_DB up for TPSW-normalised products, else down from
        the 99.9th percentile).
    truth : bool
        Mark each truth source's Doppler-shifted tonals at its cone angle, at the middle of
        the window, when the recording holds ``/truth``.
    file : str
        The file name in the title.

    Returns
    -------
    matplotlib Figure
    """
    t, f = np.asarray(g["time"], float), np.asarray(g["freq"], float)
    cone = np.asarray(g["cone_deg"], float)
    order = np.argsort(cone, kind="stable")
    cone = cone[order]
    p = np.asarray(g["power_db"], float)[:, order, :]
    top_row = np.nanmax(p, axis=0)
    m = top_row + 10 * np.log10(np.nanmean(10 ** ((p - top_row) / 10), axis=0))  # (beam, f)
    norm = as_text(g["attrs"].get("normalise", "none"))
    top = TPSW_FLOOR_DB + range_db if norm == "tpsw" else robust_top(m)
    fig, ax, new = subplots(ax, LAYOUT)
    dc = float(np.median(np.diff(cone))) if cone.size > 1 else 1.0
    df = float(np.median(np.diff(f))) if f.size > 1 else 1.0
    im = ax.imshow(m.T, aspect="auto", origin="lower", cmap="viridis", vmin=top - range_db,
                   vmax=top, interpolation="nearest",
                   extent=[cone[0] - dc / 2, cone[-1] + dc / 2, f[0] - df / 2, f[-1] + df / 2])
    cb = fig.colorbar(im, ax=ax, pad=0.02)
    cb.set_label(("mean level over TPSW background, dB" if norm == "tpsw" else
                  f"mean power Σ|Y|², {level_label(file_units(root), '²')}")
                 + f" ({range_db:g} dB range)")
    rec = open_truth_recording(root) if truth and t.size else None
    if rec is not None:
        from arrayproc.io.truth import cone_angles, tonal_frequencies
        with rec:
            tm = np.array([0.5 * (t.min() + t.max())])
            ca = cone_angles(rec, tm)
            for i, (name, fr) in enumerate(tonal_frequencies(rec, tm).items()):
                ax.plot(np.full(fr.shape[1], ca[name][0]), fr[0], "o", mfc="none", ms=10,
                        mew=1.4, color=OVERLAY_COLOURS[i % len(OVERLAY_COLOURS)],
                        label=f"truth: {name}")
        if ax.get_legend_handles_labels()[0]:
            ax.legend(loc="upper right", fontsize=8, framealpha=0.7)
    ax.set_xlim(cone[0] - dc / 2, cone[-1] + dc / 2)
    ax.set_ylim(f[0] - df / 2, f[-1] + df / 2)
    ax.set_xlabel("cone angle (deg; 0 = forward end-fire, 90 = broadside)")
    ax.set_ylabel("frequency (Hz)")
    span = f"{t.min():.1f}-{t.max():.1f} s" if t.size else "no rows"
    ax.set_title(f"bearing-frequency, mean of {t.size} LOFAR rows over {span}\n{file}",
                 fontsize=10)
    return finish(fig, new, LAYOUT)
