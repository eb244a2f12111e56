"""Array geometry (``plot --kind geometry``): the hydrophones of a recording (or of the
recording a products file was made from) in the body frame, plan view (x forward, y
starboard) and side view (x forward, z down), each numbered by its channel."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from arrayproc.plots import finish, register_plot, subplots, write_figure
from arrayproc.plots._delay import open_recording

#: Figure size and panels of the geometry plot.
LAYOUT = {"figsize": (10.0, 7.0), "dpi": 110, "nrows": 2, "ncols": 1}


@register_plot("geometry")
def plot_geometry(path: str, out_png: str, **_: Any) -> None:
    """Draw the array of the recording ``path`` (or of a products file's recording) into
    ``out_png`` (:func:`draw_geometry`)."""
    with open_recording(path, "geometry") as rec:
        pos = np.asarray(rec.positions, float)
        channels = np.asarray(rec.channels)
    write_figure(lambda axes: draw_geometry(pos, channels, axes, file=Path(path).name),
                 out_png, LAYOUT)


def spacing_stats(pos: np.ndarray) -> tuple[float, float]:
    """Aperture (largest distance between two elements, m) and median nearest-neighbour
    spacing (m) of element positions (n, 3)."""
    if pos.shape[0] < 2:
        return 0.0, 0.0
    d = np.linalg.norm(pos[:, None, :] - pos[None, :, :], axis=2)
    np.fill_diagonal(d, np.inf)
    return float(np.max(np.where(np.isfinite(d), d, 0.0))), float(np.median(d.min(axis=1)))


def draw_geometry(pos: np.ndarray, channels: np.ndarray | None = None, axes: Any = None,
                  file: str = "") -> Any:
    """Draw element positions in the body frame on two axes: plan view (x forward across,
    y starboard down the page as seen from above) and side view (z down).

    Parameters
    ----------
    pos : (n, 3) array
        Element positions, body frame (x forward, y starboard, z down), m.
    channels : (n,) int array, optional
        The channel number of each element (default 0…n−1), written beside it.
    axes : pair of matplotlib Axes, optional
        Where to draw (default: a new figure).
    file : str
        The file name in the title.

    Returns
    -------
    matplotlib Figure
    """
    pos = np.asarray(pos, float).reshape(-1, 3)
    ch = np.arange(pos.shape[0]) if channels is None else np.asarray(channels)
    fig, (a1, a2), new = subplots(axes, LAYOUT)
    label_every = max(1, pos.shape[0] // 16)
    xlo, xhi = min(pos[:, 0].min(), 0.0), max(pos[:, 0].max(), 0.0)
    pad = max(0.05 * (xhi - xlo), 0.1)
    for ax, j, lab in ((a1, 1, "y starboard (m)"), (a2, 2, "z down (m)")):
        ax.plot(pos[:, 0], pos[:, j], "o", color="tab:blue", ms=5)
        names: dict[tuple[float, float], list[str]] = {}  # elements on one point share a label
        tol = 1e-3 * max(xhi - xlo, 1e-3)
        for k in range(0, pos.shape[0], label_every):
            key = (round(pos[k, 0] / tol), round(pos[k, j] / tol))
            names.setdefault(key, []).append(str(int(ch[k])))
        for (kx, ky), lab_k in names.items():
            ax.annotate(",".join(lab_k), (kx * tol, ky * tol), xytext=(3, 4),
                        textcoords="offset points", fontsize=7)
        ax.plot([0.0], [0.0], "k+", ms=12, mew=1.5)
        ax.set_ylabel(lab)
        ax.grid(True, alpha=0.3)
        ax.set_xlim(xlo - pad, xhi + pad)
        ylo, yhi = min(pos[:, j].min(), 0.0), max(pos[:, j].max(), 0.0)
        if yhi - ylo < 0.02 * (xhi - xlo):  # a line: the flat axis gets room, not equal axes
            half = max(0.05 * (xhi - xlo), 0.5)
            ax.set_ylim(half, -half)  # starboard / down drawn below the forward axis
        else:
            ypad = max(0.05 * (yhi - ylo), 0.1)
            ax.set_ylim(yhi + ypad, ylo - ypad)
            ax.set_aspect("equal", adjustable="box")
    a1.set_xlabel("x forward (m)")
    a2.set_xlabel("x forward (m)")
    a1.set_title("plan view (from above; +: body-frame origin)", fontsize=9)
    a2.set_title("side view (from starboard)", fontsize=9)
    ap, dmin = spacing_stats(pos)
    fig.suptitle(f"array geometry: {pos.shape[0]} hydrophones, aperture {ap:.2f} m, "
                 f"median spacing {dmin:.3f} m\n{file}", fontsize=10)
    return finish(fig, new, LAYOUT)
