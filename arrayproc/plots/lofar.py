"""LOFAR plot: frequency across, time running down, for one beam, fixed dB dynamic range."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from arrayproc.io.units import file_units, level_label
from arrayproc.plots import finish, register_plot, subplots, write_figure
from arrayproc.plots._passive import find_group, open_truth_recording, robust_top

#: Truth tonals are drawn while their source lies within this many degrees of the beam.
TRUTH_GATE_DEG = 10.0
#: Truth colours that stand out on viridis.
OVERLAY_COLOURS = ("tab:red", "white", "tab:orange", "magenta")
#: Bottom of the colour scale for TPSW-normalised LOFAR-grams (noise sits at 0 dB).
TPSW_FLOOR_DB = -3.0
#: Figure size and resolution of the LOFAR plot.
LAYOUT = {"figsize": (9.0, 7.5), "dpi": 110}


@register_plot("lofar")
def plot_lofar(path: str, out_png: str, range_db: float = 20.0, beam: float | None = None,
               truth: bool = True) -> None:
    """Draw the LOFAR-gram of the beam nearest cone angle ``beam`` (deg) from the first
    ``lofar`` group of ``path`` into ``out_png`` (:func:`draw_lofar`), within the plot's
    time and band limits."""
    from arrayproc.plots import limits as lim
    g, root = find_group(path, "lofar")
    g = lim.select(g, lim.rows(g["time"], what="lofar"), np.size(g["time"]))
    keep = lim.bins(g["freq"], what="lofar")
    g = {**g, "freq": np.asarray(g["freq"])[keep],
         "power_db": np.asarray(g["power_db"])[:, :, keep]}
    write_figure(lambda ax: draw_lofar(g, root, ax, range_db=range_db, beam=beam, truth=truth,
                                       file=Path(path).name), out_png, LAYOUT)


def draw_lofar(g: dict, root: dict, ax: Any = None, range_db: float = 20.0,
               beam: float | None = None, truth: bool = True, file: str = "") -> Any:
    """Draw the LOFAR-gram of one beam: frequency across, time running down.

    Parameters
    ----------
    g : dict
        A ``lofar`` products group (``time``, ``freq``, ``cone_deg``, ``power_db`` (n, beams,
        bins), ``attrs``), as :func:`arrayproc.io.products.read_products` gives.
    root : dict
        The products file's root attributes (``units``; ``source``, for the truth).
    ax : matplotlib Axes, optional
        Where to draw (default: a new figure).
    range_db : float
        Colour span, dB: from TPSW_FLOOR_DB up for TPSW-normalised products (background =
        0 dB), otherwise down from the 99.9th percentile of that beam's record.
    beam : float, optional
        Cone angle (deg) of the beam shown (the nearest); default the beam with the highest
        mean level.
    truth : bool
        Each source's Doppler-shifted tonals as dashed lines while the source is within
        ±TRUTH_GATE_DEG of the beam, when the recording holds ``/truth``.
    file : str
        The file name shown under the title.

    Returns
    -------
    matplotlib Figure
    """
    t, f, cone, p = g["time"], g["freq"], g["cone_deg"], g["power_db"]
    if beam is None:
        b = int(np.argmax(np.nanmean(p, axis=(0, 2)))) if p.size else 0
    else:
        b = int(np.argmin(np.abs(cone - float(beam))))
    pb = p[:, b, :]
    norm = str(g["attrs"].get("normalise", "none"))
    if norm == "tpsw":  # background at 0 dB: the scale starts just below it
        top = TPSW_FLOOR_DB + range_db
    else:
        top = robust_top(pb)
    fig, ax, new = subplots(ax, LAYOUT)
    dt = np.median(np.diff(t)) if t.size > 1 else 1.0
    df = np.median(np.diff(f)) if f.size > 1 else 1.0
    im = ax.imshow(pb, aspect="auto", cmap="viridis",
                   vmin=top - range_db, vmax=top,
                   extent=[f[0] - df / 2, f[-1] + df / 2, t[-1] + dt / 2, t[0] - dt / 2],
                   interpolation="nearest")
    cb = fig.colorbar(im, ax=ax, pad=0.02)
    cb.set_label(("level over TPSW background, dB" if norm == "tpsw"
                  else f"power Σ|Y|², {level_label(file_units(root), '²')}, unnormalised")
                 + f" ({range_db:g} dB range)")
    rec = open_truth_recording(root) if truth else None
    if rec is not None:
        from arrayproc.io.truth import cone_angles, tonal_frequencies
        with rec:
            cones = cone_angles(rec, t)
            first = True
            for i, (name, fr) in enumerate(tonal_frequencies(rec, t).items()):
                near = np.abs(cones[name] - cone[b]) <= TRUTH_GATE_DEG
                for k in range(fr.shape[1]):
                    ff = np.where(near, fr[:, k], np.nan)
                    if np.all(np.isnan(ff)):
                        continue
                    ax.plot(ff, t, ls=(0, (2, 6)), lw=0.8, alpha=0.5,
                            color=OVERLAY_COLOURS[i % len(OVERLAY_COLOURS)],
                            label=f"truth: {name}" if k == 0 else None)
                    first = False
            if not first:
                ax.legend(loc="lower right", fontsize=8, framealpha=0.7)
    ax.set_xlim(f[0] - df / 2, f[-1] + df / 2)
    ax.set_ylim(t[-1] + dt / 2, t[0] - dt / 2)
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("time (s since recording start)")
    ax.set_title(f"LOFAR, beam {cone[b]:.1f} deg cone angle\n{file}", fontsize=10)
    return finish(fig, new, LAYOUT)
