"""Positions plot: localised events in plan (x east, y north) and side (x east, depth down)
views around the array, with 1σ error ellipses from the ``cov`` column."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from arrayproc.errors import ArrayprocError
from arrayproc.plots import finish, register_plot, subplots, write_figure
from arrayproc.plots._delay import ellipse, groups_of

#: Figure size, resolution, panels and layout engine of the positions plot.
LAYOUT = {"figsize": (12.0, 6.2), "dpi": 110, "layout": "constrained", "nrows": 1, "ncols": 2}


def _elements(root: dict) -> np.ndarray | None:
    src = root.get("source", "")
    src = src.decode() if isinstance(src, bytes) else str(src)
    if not src or not Path(src).is_file():
        return None
    from arrayproc.io.recording import Recording
    try:
        with Recording(src) as rec:
            return np.asarray(rec.pose(0.0).elements, float)
    except Exception:  # noqa: BLE001 - the array is an optional overlay
        return None


@register_plot("positions")
def plot_positions(path: str, out_png: str, span: float | None = None,
                   n_sigma: float = 1.0, range_db: float | None = None,
                   beam: float | None = None, truth: bool = True) -> None:
    """Draw the ``positions`` of products file ``path`` into ``out_png``.

    Parameters
    ----------
    path : str
        Products file holding a ``positions`` group.
    out_png : str
        Output image.
    span : float, optional
        Half-width of the views around the array centre, m (default: fits 90 % of the
        events, at least 2 m; the title counts the events outside).
    n_sigma : float
        Size of the error ellipses in standard deviations.
    range_db, beam, truth
        Options of the other plots, unused here.
    """
    found, root = groups_of(path, "positions")
    name, g = found[0]
    if "x" not in g:
        raise ArrayprocError(f"{path}: positions product is empty (no rows)")
    el = _elements(root)
    write_figure(lambda axes: draw_positions(g, el, axes, span=span, n_sigma=n_sigma,
                                             name=f"{name}", file=Path(path).name),
                 out_png, LAYOUT)


def draw_positions(g: dict, elements: np.ndarray | None = None, axes: Any = None,
                   span: float | None = None, n_sigma: float = 1.0, name: str = "positions",
                   file: str = "") -> Any:
    """Draw a ``positions`` products group in plan and side views on two axes (default: a
    new figure), with ``n_sigma`` error ellipses, coloured by time; ``elements`` (n, 3) m,
    the hydrophones, when known. ``span`` as in :func:`plot_positions`; ``name`` the group
    and ``file`` the file named in the title. Returns the matplotlib Figure.
    """
    from matplotlib import colormaps

    el = elements
    p = np.stack([g["x"], g["y"], g["z"]], axis=1)
    cov, t = g["cov"], g["time"]
    centre = el.mean(axis=0) if el is not None else np.median(p, axis=0)
    far = np.max(np.abs(p - centre), axis=1) if p.size else np.zeros(0)
    if span is None:
        span = max(2.0, 1.3 * float(np.percentile(far, 90))) if p.size else 5.0
    n_out = int(np.sum(far > span))
    fig, (a1, a2), new = subplots(axes, LAYOUT)
    cmap = colormaps["plasma"]
    tn = (t - t.min()) / max(np.ptp(t), 1e-9)
    for ax, (i, j), lab in ((a1, (0, 1), "y north (m)"), (a2, (0, 2), "z depth (m, down)")):
        for k in range(p.shape[0]):
            e = ellipse(cov[k][np.ix_([i, j], [i, j])], p[k, [i, j]], n_sigma)
            ax.plot(e[:, 0], e[:, 1], color=cmap(tn[k]), lw=0.8, alpha=0.8)
        sc = ax.scatter(p[:, i], p[:, j], c=t, cmap=cmap, s=18, zorder=3, label="events")
        if el is not None:
            ax.scatter(el[:, i], el[:, j], marker="^", c="k", s=40, zorder=4,
                       label="hydrophones")
        ax.set_xlim(centre[i] - span, centre[i] + span)
        ax.set_ylim(centre[j] - span, centre[j] + span)
        ax.set_aspect("equal")
        ax.set_xlabel("x east (m)")
        ax.set_ylabel(lab)
        ax.grid(True, alpha=0.3)
    a2.invert_yaxis()
    a1.set_title("plan view")
    a2.set_title("side view (looking north)")
    a1.legend(loc="upper right", fontsize=8)
    cb = fig.colorbar(sc, ax=[a1, a2], pad=0.02, shrink=0.8)
    cb.set_label("event time (s since recording start)")
    out_txt = f", {n_out} outside the view" if n_out else ""
    fig.suptitle(f"{p.shape[0]} localised events with {n_sigma:g}σ ellipses ({name}"
                 f"{out_txt})\n{file}", fontsize=10)
    return finish(fig, new, LAYOUT)
