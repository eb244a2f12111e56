"""RMSE-versus-time curves with a CRLB, and the scenario geometry (SPL paper figs. 2-7)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from arrayproc.plots import finish, subplots, write_figure

__all__ = ["plot_rmse_curves", "plot_scenario_geometry"]

#: Figure sizes and layout engine of the two plots.
CURVES_LAYOUT = {"figsize": (7.5, 4.5), "constrained_layout": True}
GEOMETRY_LAYOUT = {"figsize": (5.5, 5.0), "constrained_layout": True}


def plot_rmse_curves(time_min: np.ndarray, curves: Mapping[str, np.ndarray],
                     out_png: str | None = None, crlb: np.ndarray | None = None,
                     title: str = "", paper_points: Mapping[str, tuple] | None = None,
                     logy: bool = True, ax: Any = None) -> Any:
    """Position RMSE (m) against time (min), one line per curve, the CRLB dashed: into
    ``out_png`` (dpi 120), or on ``ax`` (default: a new figure), returning the Figure.

    ``paper_points``: label → (times_min, values_m) drawn as markers (published numbers).
    """
    if out_png is not None and ax is None:
        write_figure(lambda a: plot_rmse_curves(time_min, curves, None, crlb, title,
                                                paper_points, logy, a),
                     out_png, CURVES_LAYOUT, dpi=120)
        return None
    fig, ax, new = subplots(ax, CURVES_LAYOUT)
    colours = ["tab:blue", "tab:red", "tab:green", "tab:purple"]
    for (label, y), c in zip(curves.items(), colours, strict=False):
        ax.plot(time_min, y, color=c, lw=1.6, label=label)
    if crlb is not None:
        ax.plot(time_min, crlb, "k--", lw=1.2, label="CRLB (bearings only, zero process noise)")
    for (label, (t, v)), c in zip((paper_points or {}).items(), colours, strict=False):
        ax.plot(t, v, "o", mfc="none", color=c, ms=7, label=label)
    if logy:
        ax.set_yscale("log")
    ax.set_xlabel("time (min)")
    ax.set_ylabel("position RMSE (m)")
    ax.set_xlim(time_min[0], time_min[-1])
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    if title:
        ax.set_title(title)
    return finish(fig, new, CURVES_LAYOUT)


def plot_scenario_geometry(target_xy: np.ndarray, observer_xy: np.ndarray,
                           out_png: str | None = None, title: str = "", ax: Any = None) -> Any:
    """Target and observer tracks (km), x east, y north, start points marked: into
    ``out_png`` (dpi 120), or on ``ax`` (default: a new figure), returning the Figure."""
    if out_png is not None and ax is None:
        write_figure(lambda a: plot_scenario_geometry(target_xy, observer_xy, None, title, a),
                     out_png, GEOMETRY_LAYOUT, dpi=120)
        return None
    fig, ax, new = subplots(ax, GEOMETRY_LAYOUT)
    ax.plot(target_xy[:, 0] / 1e3, target_xy[:, 1] / 1e3, "r-", label="target")
    ax.plot(observer_xy[:, 0] / 1e3, observer_xy[:, 1] / 1e3, "b-", label="observer")
    ax.plot(target_xy[0, 0] / 1e3, target_xy[0, 1] / 1e3, "rs", label="target start")
    ax.plot(observer_xy[0, 0] / 1e3, observer_xy[0, 1] / 1e3, "bo", label="observer start")
    ax.set_xlabel("x east (km)")
    ax.set_ylabel("y north (km)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    if title:
        ax.set_title(title)
    return finish(fig, new, GEOMETRY_LAYOUT)
