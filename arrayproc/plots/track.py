"""Track plots: ownship, estimate with covariance ellipses and truth; RMSE curves with the CRLB.

Axes in km (positions) and minutes (time) as in the L-R paper's figures; x east, y north.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from typing import Any

import h5py
import numpy as np

from arrayproc.errors import FormatError
from arrayproc.io.text import as_text
from arrayproc.plots import finish, register_plot, subplots, write_figure
from arrayproc.plots.ellipse import cov_ellipse

FILTER_STYLE = {"ekf": "tab:red", "ukf": "tab:blue", "ckf": "tab:green", "ghf": "tab:orange",
                "srf": "tab:purple", "rpf": "tab:brown"}
#: Figure sizes of the track plan view, the RMSE pair, the bias and the L-R example.
LAYOUT = {"figsize": (8, 7)}
RMSE_LAYOUT = {"figsize": (11, 4.2), "nrows": 1, "ncols": 2}
BIAS_LAYOUT = {"figsize": (6, 4)}
LR_LAYOUT = {"figsize": (12, 5), "nrows": 1, "ncols": 2, "gridspec_kw": {"width_ratios": [3, 2]}}


def _read_truth(recording: str) -> dict[str, np.ndarray]:
    out: dict[str, np.ndarray] = {}
    if not recording or not os.path.exists(recording):
        return out
    try:
        with h5py.File(recording, "r") as f:
            if "truth/sources" in f:
                for name, g in f["truth/sources"].items():
                    if "position" in g:
                        out[name] = np.asarray(g["position"][()], float)
    except OSError:
        return {}
    return out


@register_plot("track")
def plot_track(tracks_path: str, out_png: str, ellipse_every: int | None = None,
               truth: Mapping[str, np.ndarray] | bool | None = None, title: str | None = None,
               **_: Any) -> None:
    """Plan view of a tracks file read at a glance: the ownship path; each track in its own
    colour with its id at its last point (multi-target files: confirmed rows once the
    left-right weight of one side reaches 90 %; a single-target file starts at its first
    update, not at the prior); 2σ position ellipses
    every ``ellipse_every`` rows (default: about six per track); the truth of each source in
    its own dashed colour, named at its end (``truth`` {name: (n, 2) m}, or the recording's
    ``/truth/sources`` when the tracks file names it; False: none), over the tracks' time
    span (:func:`draw_track`)."""
    from arrayproc.io.products import read_products

    prod = read_products(tracks_path)
    groups = list(prod.groups("tracks").values())
    if not groups:
        raise FormatError(f"{tracks_path}: no tracks group")
    g = groups[0]
    write_figure(lambda ax: draw_track(g, prod.root, ax, ellipse_every, truth,
                                       title or f"{os.path.basename(tracks_path)} (2σ ellipses)"),
                 out_png, LAYOUT, dpi=120)


def draw_track(g: dict, root: dict, ax: Any = None, ellipse_every: int | None = None,
               truth: Mapping[str, np.ndarray] | bool | None = None, title: str = "") -> Any:
    """Draw a ``tracks`` products group in plan view (see :func:`plot_track`): ownship, each
    track with its id and 2σ ellipses, the truth (``truth`` {name: (n, 2) m}; None or True:
    the ``recording`` of ``root``'s ``/truth/sources``; False: none).

    ``ax`` is a matplotlib Axes (default: a new figure). Returns the matplotlib Figure.
    """
    from matplotlib import colormaps

    t_all = np.asarray(g["time"], float) if "time" in g else np.zeros(0)
    tspan = (float(t_all.min()), float(t_all.max())) if t_all.size else None
    truth_times: dict[str, np.ndarray] = {}
    if truth is None or truth is True:
        rec = root.get("recording", "")
        truth, truth_times = _read_truth_timed(rec.decode() if isinstance(rec, bytes)
                                               else str(rec))
    elif truth is False:
        truth = {}
    fig, ax, new = subplots(ax, LAYOUT)
    if "own_x" in g and t_all.size:
        o = np.argsort(t_all, kind="stable")
        ax.plot(g["own_x"][o] / 1e3, g["own_y"][o] / 1e3, "k-", lw=2, label="ownship")
        ax.plot(g["own_x"][o][0] / 1e3, g["own_y"][o][0] / 1e3, "ko", ms=5)
    tcol = colormaps["Dark2"]
    for k, (name, p) in enumerate(sorted(truth.items())):
        if name in truth_times and tspan is not None:
            tt = truth_times[name]
            keep = (tt >= tspan[0]) & (tt <= tspan[1])
            p = p[keep] if keep.any() else p
        c = tcol(k % 8)
        ax.plot(p[:, 0] / 1e3, p[:, 1] / 1e3, "--", color=c, lw=2.2, alpha=0.8,
                label=f"truth {name}")
        ax.annotate(name, (p[-1, 0] / 1e3, p[-1, 1] / 1e3), color=c, fontsize=9,
                    xytext=(4, -10), textcoords="offset points", fontstyle="italic")
    multi = as_text(dict(g.get("attrs") or {}).get("mode", "")) == "multi"
    from arrayproc.track.manage.tracks import status_names
    status = status_names(g["status"]) if "status" in g else None
    ids = np.unique(g["track_id"])
    cmap = colormaps["tab10"]
    for k, tid in enumerate(ids):
        m = np.flatnonzero(g["track_id"] == tid)
        m = m[np.argsort(t_all[m], kind="stable")]
        if status is not None and multi:
            m = m[status[m] == "confirmed"]
        elif m.size > 1:
            m = m[1:]  # the first row of a single-target file is the prior
        if multi and "side_weight" in g:
            # before the left-right ambiguity resolves, eq. (12) averages the two mirror
            # hypotheses onto the array axis: show positions once one side holds 90 %
            sw = np.asarray(g["side_weight"], float)[m]
            m = m[~np.isfinite(sw) | (np.abs(sw - 0.5) >= 0.4)]
        if m.size == 0:
            continue
        x, y, cov = g["x"][m], g["y"][m], g["cov"][m]
        c = cmap(k % 10)
        ax.plot(x / 1e3, y / 1e3, ".-", color=c, ms=2.5, lw=1.2, label=f"track {tid}")
        every = int(ellipse_every) if ellipse_every else max(1, x.size // 6)
        for i in range(every // 2, x.size, max(1, every)):
            cov_ellipse(ax, np.array([x[i], y[i]]), cov[i, :2, :2], ec=c, lw=0.8, alpha=0.7)
        ax.annotate(str(tid), (x[-1] / 1e3, y[-1] / 1e3), color=c, fontsize=10,
                    fontweight="bold", xytext=(4, 4), textcoords="offset points")
    ax.set_xlabel("x east (km)")
    ax.set_ylabel("y north (km)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(alpha=0.3)
    ax.legend(loc="best", fontsize=8, ncol=2)
    ax.set_title(title)
    return finish(fig, new, LAYOUT)


def _read_truth_timed(recording: str) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Truth positions {name: (n, 2) m} and their times {name: (n,) s} of a recording."""
    pos: dict[str, np.ndarray] = {}
    times: dict[str, np.ndarray] = {}
    if not recording or not os.path.exists(recording):
        return pos, times
    try:
        with h5py.File(recording, "r") as f:
            if "truth/sources" in f:
                for name, g in f["truth/sources"].items():
                    if "position" in g:
                        pos[name] = np.asarray(g["position"][()], float)
                        if "time" in g:
                            times[name] = np.asarray(g["time"][()], float).reshape(-1)
    except OSError:
        return {}, {}
    return pos, times


def _to_file(draw: Any, out_png: str | None, layout: Mapping[str, Any]) -> Any:
    """``draw(axes)`` into ``out_png`` (dpi 120) when given, else on a new figure, returned."""
    if out_png is None:
        return draw(None)
    write_figure(draw, out_png, layout, dpi=120)
    return None


def plot_rmse(times_s: np.ndarray, curves: Mapping[str, tuple[np.ndarray, np.ndarray]],
              out_png: str | None = None, bound_pos_m: np.ndarray | None = None,
              title: str = "", axes: Any = None) -> Any:
    """Position and velocity RMSE against time for several filters ({name: (pos m, vel m/s)}),
    with the position CRLB when given (L-R paper figs. 5 and 7): into ``out_png``, or on
    ``axes`` (two matplotlib Axes; default a new figure), returning the Figure."""
    if out_png is not None and axes is None:
        return _to_file(lambda a: plot_rmse(times_s, curves, None, bound_pos_m, title, a),
                        out_png, RMSE_LAYOUT)
    t = np.asarray(times_s) / 60.0
    fig, (a1, a2), new = subplots(axes, RMSE_LAYOUT)
    for name, (pos, vel) in curves.items():
        c = FILTER_STYLE.get(name.split()[0].lower())
        a1.plot(t, pos / 1e3, color=c, label=name.upper())
        a2.plot(t, vel, color=c, label=name.upper())
    if bound_pos_m is not None:
        a1.plot(t, np.asarray(bound_pos_m) / 1e3, "k--", label="CRLB (zero process noise)")
    a1.set_xlabel("time (min)")
    a1.set_ylabel("position RMSE (km)")
    a2.set_xlabel("time (min)")
    a2.set_ylabel("velocity RMSE (m/s)")
    a1.set_yscale("log")
    a2.set_yscale("log")
    for a in (a1, a2):
        a.grid(alpha=0.3, which="both")
        a.legend(fontsize=8)
    fig.suptitle(title)
    return finish(fig, new, RMSE_LAYOUT)


def plot_bias(times_s: np.ndarray, curves: Mapping[str, np.ndarray], out_png: str | None = None,
              title: str = "", ax: Any = None) -> Any:
    """Bias norm ‖mean position error‖ (m) against time (L-R paper fig. 6): into ``out_png``,
    or on ``ax`` (default a new figure), returning the Figure."""
    if out_png is not None and ax is None:
        return _to_file(lambda a: plot_bias(times_s, curves, None, title, a), out_png,
                        BIAS_LAYOUT)
    t = np.asarray(times_s) / 60.0
    fig, ax, new = subplots(ax, BIAS_LAYOUT)
    for name, b in curves.items():
        ax.plot(t, np.asarray(b) / 1e3, color=FILTER_STYLE.get(name.lower()),
                label=name.upper())
    ax.set_xlabel("time (min)")
    ax.set_ylabel("position bias norm (km)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(title)
    return finish(fig, new, BIAS_LAYOUT)


def plot_lr_example(own: np.ndarray, truth: np.ndarray, known: np.ndarray,
                    resolved: np.ndarray, ghost: np.ndarray, weights: np.ndarray,
                    times_s: np.ndarray, out_png: str | None = None,
                    labels: Sequence[str] = (), title: str = "", axes: Any = None) -> Any:
    """One run (L-R paper fig. 4): ownship, truth, known-side estimate, L-R resolved estimate
    and the ghost hypothesis (absolute positions, m) while its weight 1 − ω¹ is at least 1 %,
    and the true-side weight ω¹ over time: into ``out_png``, or on ``axes`` (two matplotlib
    Axes; default a new figure), returning the Figure."""
    if out_png is not None and axes is None:
        return _to_file(lambda a: plot_lr_example(own, truth, known, resolved, ghost, weights,
                                                  times_s, None, labels, title, a),
                        out_png, LR_LAYOUT)
    fig, (a1, a2), new = subplots(axes, LR_LAYOUT)
    a1.plot(own[:, 0] / 1e3, own[:, 1] / 1e3, "k-", label="ownship")
    a1.plot(truth[:, 0] / 1e3, truth[:, 1] / 1e3, "g-", lw=2, label="target (truth)")
    a1.plot(resolved[:, 0] / 1e3, resolved[:, 1] / 1e3, "*-", color="tab:orange", ms=6,
            lw=2.5, label="L-R resolved (eq. 12)")
    a1.plot(known[:, 0] / 1e3, known[:, 1] / 1e3, "b.--", ms=3, lw=1, label="known side")
    alive = np.flatnonzero(1.0 - np.asarray(weights) >= 0.01)
    last = (alive.max() + 1) if alive.size else 1
    a1.plot(ghost[:last, 0] / 1e3, ghost[:last, 1] / 1e3, "x:", color="tab:red", ms=4,
            label="ghost hypothesis (while ω² ≥ 1 %)")
    a1.set_xlabel("x east (km)")
    a1.set_ylabel("y north (km)")
    a1.set_aspect("equal", adjustable="datalim")
    a1.grid(alpha=0.3)
    a1.legend(fontsize=8)
    a2.plot(np.asarray(times_s) / 60.0, weights, "o-", ms=3)
    a2.set_xlabel("time (min)")
    a2.set_ylabel("weight of the true-side filter ω¹")
    a2.set_ylim(-0.05, 1.05)
    a2.grid(alpha=0.3)
    fig.suptitle(title)
    return finish(fig, new, LR_LAYOUT)
