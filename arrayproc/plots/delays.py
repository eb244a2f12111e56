"""Delays plot: the ``delays`` product over time per channel (delay across, time running
down), with ±σ bars."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from arrayproc.errors import ArrayprocError
from arrayproc.plots import finish, register_plot, subplots, write_figure
from arrayproc.plots._delay import groups_of

#: Figure size and resolution of the delays plot.
LAYOUT = {"figsize": (8.0, 8.0), "dpi": 110}


@register_plot("delays")
def plot_delays(path: str, out_png: str, min_corr: float = 0.0, range_db: float | None = None,
                beam: float | None = None, truth: bool = True) -> None:
    """Draw the first ``delays`` group of products file ``path`` into ``out_png``.

    Parameters
    ----------
    path : str
        Products file holding a ``delays`` group.
    out_png : str
        Output image.
    min_corr : float
        Delays with a lower normalised correlation are drawn hollow.
    range_db, beam, truth
        Options of the other plots, unused here.
    """
    found, _ = groups_of(path, "delays")
    name, g = found[0]
    if "time" not in g:
        raise ArrayprocError(f"{path}: delays product is empty (no rows)")
    write_figure(lambda ax: draw_delays(g, ax, min_corr=min_corr, name=name,
                                        file=Path(path).name), out_png, LAYOUT)


def draw_delays(g: dict, ax: Any = None, min_corr: float = 0.0, name: str = "delays",
                file: str = "") -> Any:
    """Draw a ``delays`` products group: each channel's delay across, time running down,
    with ±1σ bars; delays whose correlation is below ``min_corr`` hollow.

    ``ax`` is a matplotlib Axes (default: a new figure); ``name`` the group and ``file`` the
    file named in the title. Returns the matplotlib Figure.
    """
    t, tau, sig, corr = g["time"], g["tau"], g["sigma"], g["corr"]
    ref = int(g["attrs"].get("reference", 0))
    fig, ax, new = subplots(ax, LAYOUT)
    for ch in range(tau.shape[1]):
        if ch == ref:
            continue
        good = corr[:, ch] >= min_corr
        s = np.where(np.isfinite(sig[:, ch]), sig[:, ch], np.nan) * 1e3
        ax.errorbar(tau[good, ch] * 1e3, t[good], xerr=s[good], fmt="o", ms=4, lw=0.8,
                    color=f"C{ch % 10}", label=f"channel {ch}")
        if (~good).any():
            ax.plot(tau[~good, ch] * 1e3, t[~good], "o", mfc="none", ms=4,
                    color=f"C{ch % 10}")
    ax.invert_yaxis()
    ax.set_xlabel(f"delay relative to channel {ref} (ms)")
    ax.set_ylabel("time (s since recording start)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="lower right")
    extra = f"; hollow: corr < {min_corr:g}" if min_corr > 0 else ""
    ax.set_title(f"delays ±1σ ({name}{extra})\n{file}", fontsize=10)
    return finish(fig, new, LAYOUT)
