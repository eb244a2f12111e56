"""Batch TMA plot (products ``tma``): plan view and measured against fitted measurements.

Left: the ownship track over the solutions' windows, each solution's constant-velocity track
over its window with the 2σ CRLB position ellipse at its start (thesis eq. (3.53)), and the
truth when the recording has ``/truth/sources``. Right: the measurements the solution was
fitted to (bearings in degrees, or the delays of a few hydrophones in milliseconds) against
time, with the model's values at the estimate; time runs down (sonar orientation).
Positions in km, x east / y north.

A ``tma`` group of one solution per track (``arrayproc tma TRACKS.h5``, column ``track_id``)
is drawn by :func:`draw_track_tma`: the tracks plan view (:func:`.track.draw_track`: ownship,
the tracker's estimates, truth) with each track's TMA solution over its rows' span in the
track's colour and its 2σ CRLB position ellipses at the start and (propagated) the end, the
mirror solution dashed; right, each track's measured cone angles against the solution's.
"""

from __future__ import annotations

import os
from typing import Any

import h5py
import numpy as np

from arrayproc.errors import FormatError
from arrayproc.io.text import as_text
from arrayproc.plots import finish, register_plot, subplots, write_figure
from arrayproc.plots.ellipse import cov_ellipse

#: Figure size and panels of the TMA plot.
LAYOUT = {"figsize": (12, 6), "nrows": 1, "ncols": 2}


def _truth(path: str) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    out: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    if not path or not os.path.exists(path):
        return out
    with h5py.File(path, "r") as f:
        if "truth/sources" not in f:
            return out
        for name, g in f["truth/sources"].items():
            if isinstance(g, h5py.Group) and "time" in g and "position" in g:
                out[name] = (np.asarray(g["time"][()], float),
                             np.asarray(g["position"][()], float))
    return out


@register_plot("tma")
def plot_tma(path: str, out_png: str, truth: bool = True, **_: Any) -> None:
    """Draw the ``tma`` group of a products file (see the module docstring).

    Parameters
    ----------
    path : str
        Products file written by ``arrayproc tma``.
    out_png : str
        Image file.
    truth : bool
        Overlay the recording's truth when it has one.
    """
    from arrayproc.io.products import read_products

    prod = read_products(path)
    names = list(prod.groups("tma"))
    if not names:
        raise FormatError(f"{path}: no tma group")
    g = prod[names[0]]
    write_figure(lambda axes: draw_tma(g, prod.root, axes, truth=truth), out_png, LAYOUT,
                 dpi=110)


def draw_tma(g: dict, root: dict, axes: Any = None, truth: bool = True) -> Any:
    """Draw a ``tma`` products group on two axes (default: a new figure): the plan view and
    the measurements against the fitted model (module doc). The recording (navigation,
    truth) and the measurements are those the group's attributes name (``recording``, else
    ``root``'s ``source``; ``products``). Returns the matplotlib Figure.
    """
    from arrayproc.io.recording import Recording
    from arrayproc.track.batch.bo_tma import bearing_model
    from arrayproc.track.batch.compact import compact_bearings
    from arrayproc.track.batch.run import read_measurements
    from arrayproc.track.batch.td_tma import delay_model

    a = g["attrs"]
    if "track_id" in g and as_text(a.get("tracks", "")):
        return draw_track_tma(g, root, axes, truth=truth)
    method = as_text(a.get("method", ""))
    rec_path = as_text(a.get("recording", root.get("source", "")))
    src_path = as_text(a.get("products", ""))
    sides = as_text(a.get("side", "")).split(",")
    n = g["x"].shape[0]
    fig, (ax, axm), new = subplots(axes, LAYOUT)
    t_all = np.concatenate([np.linspace(g["t0"][i], g["t1"][i], 50) for i in range(n)])
    rec = Recording(rec_path) if rec_path and os.path.exists(rec_path) else None
    try:
        if rec is not None:
            tt = np.linspace(t_all.min(), t_all.max(), 400)
            own = rec.nav.at(tt)[0]
            ax.plot(own[:, 0] / 1e3, own[:, 1] / 1e3, "k-", lw=2, label="ownship")
            ax.plot(own[0, 0] / 1e3, own[0, 1] / 1e3, "ko")
        if truth and rec is not None:
            for k, (tt_s, pos) in _truth(rec_path).items():
                sel = (tt_s >= t_all.min()) & (tt_s <= t_all.max())
                ax.plot(pos[sel, 0] / 1e3, pos[sel, 1] / 1e3, "g--", lw=1.5,
                        label=f"truth {k}")
        for i in range(n):
            st = np.array([g["x"][i], g["y"][i], g["vx"][i], g["vy"][i]])
            tau = np.linspace(0.0, g["t1"][i] - g["t0"][i], 50)
            tr = st[None, :2] + tau[:, None] * st[None, 2:]
            ax.plot(tr[:, 0] / 1e3, tr[:, 1] / 1e3, "r-", label="estimate" if i == 0 else None)
            ax.plot(st[0] / 1e3, st[1] / 1e3, "r.")
            c = g["crlb"][i]
            if np.all(np.isfinite(c[:2, :2])):
                cov_ellipse(ax, st[:2], c[:2, :2], edgecolor="r",
                         label="2σ CRLB at t0" if i == 0 else None)
        ax.set_xlabel("x east (km)")
        ax.set_ylabel("y north (km)")
        ax.set_aspect("equal", adjustable="datalim")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
        ax.set_title(f"{method} TMA: {n} solution(s); dots: window starts")

        meas = None
        if src_path and os.path.exists(src_path) and rec is not None:
            meas = read_measurements(src_path, {
                "method": method, "group": as_text(a.get("measurements", "")), "cone_gate": None})
        if meas is None:
            axm.text(0.5, 0.5, "measurements unavailable\n(products or recording missing)",
                     ha="center", transform=axm.transAxes)
        else:
            t = meas["time"]
            for i in range(n):
                st = np.array([g["x"][i], g["y"][i], g["vx"][i], g["vy"][i]])
                sel = (t >= g["t0"][i]) & (t <= g["t1"][i])
                ts = t[sel]
                poses = rec.poses(ts)
                lab = i == 0
                if method == "delays":
                    elem = np.stack([p.elements[:, :2] for p in poses])
                    ref = meas["reference"]
                    fit = delay_model(st, ts - g["t0"][i], elem, ref, rec.sound_speed,
                                      retarded=bool(a.get("retarded_time", 0)))
                    chans = np.unique(np.linspace(0, elem.shape[1] - 1, 5).astype(int))
                    chans = chans[chans != ref]
                    for k in chans:
                        axm.plot(1e3 * meas["tau"][sel, k], ts, ".", ms=3,
                                 label=f"measured ch {k}" if lab else None)
                        axm.plot(1e3 * fit[:, k], ts, "k-", lw=1,
                                 label="fitted" if lab and k == chans[0] else None)
                    axm.set_xlabel("delay to the reference hydrophone (ms)")
                else:
                    obs = np.stack([p.elements[:, :2].mean(0) for p in poses])
                    side = sides[i] if i < len(sides) else ""
                    y = meas["port"][sel] if side == "port" else meas["stbd"][sel]
                    if method == "compact":
                        q = np.array([st[0], st[1], np.arctan2(st[2], st[3])])
                        fit = compact_bearings(q, np.hypot(st[2], st[3]), ts - g["t0"][i],
                                               obs.mean(0))
                    else:
                        fit = bearing_model(st, ts - g["t0"][i], obs, rec.sound_speed
                                            if a.get("retarded_time", 0) else None)
                    axm.plot(np.degrees(y) % 360, ts, "b.", ms=3,
                             label=f"measured ({side or 'bearing'})" if lab else None)
                    axm.plot(np.degrees(fit) % 360, ts, "r-", label="fitted" if lab else None)
                    axm.set_xlabel("bearing (deg true)")
            axm.invert_yaxis()
            axm.set_ylabel("time (s)")
            axm.grid(True, alpha=0.3)
            axm.legend(fontsize=8)
            axm.set_title("measured vs fitted (time runs down)")
    finally:
        if rec is not None:
            rec.close()
    return finish(fig, new, LAYOUT)


def _propagated(st: np.ndarray, crlb: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Constant-velocity state and CRLB ``dt`` later (``F P Fᵀ``)."""
    f = np.eye(4)
    f[0, 2] = f[1, 3] = dt
    return f @ st, f @ crlb @ f.T


def draw_track_tma(g: dict, root: dict, axes: Any = None, truth: bool = True) -> Any:
    """Draw a per-track ``tma`` group (module doc) on two axes (default: a new figure); the
    tracks file, the recording and the measurements are those the group's attributes name
    (``tracks``, ``recording``). Returns the matplotlib Figure."""
    from matplotlib import colormaps

    from arrayproc.io.products import read_products
    from arrayproc.io.recording import Recording
    from arrayproc.plots.track import draw_track
    from arrayproc.track.batch.bo_tma import cone_model
    from arrayproc.track.batch.per_track import read_track_rows
    from arrayproc.track.batch.run import PARAMS

    a = g["attrs"]
    tracks_path = as_text(a.get("tracks", ""))
    rec_path = as_text(a.get("recording", root.get("source", "")))
    fig, (ax, axm), new = subplots(axes, LAYOUT)
    have_tracks = os.path.exists(tracks_path)
    if have_tracks:
        tp = read_products(tracks_path)
        tg = next(iter(tp.groups("tracks").values()))
        draw_track(tg, tp.root, ax, ellipse_every=10**9, truth=None if truth else False)
        all_ids = list(np.unique(tg["track_id"]))
    else:
        all_ids = list(np.unique(g["track_id"]))
    cmap = colormaps["tab10"]
    ids = np.asarray(g["track_id"])
    pref = np.asarray(g["preferred"], int) if "preferred" in g else np.ones(ids.size, int)
    for i in range(ids.size):
        c = cmap(all_ids.index(ids[i]) % 10) if ids[i] in all_ids else "r"
        st = np.array([g["x"][i], g["y"][i], g["vx"][i], g["vy"][i]])
        dt = float(g["t1"][i] - g["t0"][i])
        tau = np.linspace(0.0, dt, 50)
        tr = st[None, :2] + tau[:, None] * st[None, 2:]
        ls, lw = ("-", 3.0) if pref[i] else ("--", 1.2)
        what = as_text(g["method"][i])
        lab = f"TMA {ids[i]} ({what}{'' if pref[i] else ', mirror'})"
        ax.plot(tr[:, 0] / 1e3, tr[:, 1] / 1e3, ls, color=c, lw=lw, alpha=0.6, label=lab)
        ax.plot(st[0] / 1e3, st[1] / 1e3, "o", color=c, ms=5, mfc="none")
        crlb = g["crlb"][i]
        if np.all(np.isfinite(crlb)):
            cov_ellipse(ax, st[:2], crlb[:2, :2], edgecolor=c, lw=2 if pref[i] else 0.8,
                        linestyle=ls)
            s1, p1 = _propagated(st, crlb, dt)
            cov_ellipse(ax, s1[:2], p1[:2, :2], edgecolor=c, lw=2 if pref[i] else 0.8,
                        linestyle=ls)
    ax.set_xlabel("x east (km)")
    ax.set_ylabel("y north (km)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, ncol=2, loc="best")
    ax.set_title("per-track TMA: thick = preferred, 2σ CRLB at start and end; "
                 "thin dots = tracker", fontsize=9)
    rows = None
    if have_tracks and rec_path and os.path.exists(rec_path):
        cfg = PARAMS.check({"method": "bearings"}, tracks_path, prefix="tma.")
        try:
            rows = read_track_rows(tracks_path, cfg)
        except Exception:  # noqa: BLE001 — the products file moved: the panel says so
            rows = None
    if rows is None:
        axm.text(0.5, 0.5, "measurements unavailable\n(tracks, products or recording missing)",
                 ha="center", transform=axm.transAxes)
    else:
        with Recording(rec_path) as rec:
            for i in range(ids.size):
                m = rows.tracks.get(int(ids[i]))
                if m is None or not pref[i]:
                    continue
                c = cmap(all_ids.index(ids[i]) % 10)
                t = m["time"]
                poses = rec.poses(t)
                obs = np.stack([p.elements[:, :2].mean(0) for p in poses])
                hd = np.deg2rad([p.heading for p in poses])
                st = np.array([g["x"][i], g["y"][i], g["vx"][i], g["vy"][i]])
                fit = cone_model(st, t - g["t0"][i], obs, hd,
                                 rec.sound_speed if a.get("retarded_time", 0) else None)
                axm.plot(np.degrees(m["cone"]), t, ".", color=c, ms=3,
                         label=f"track {ids[i]} measured")
                axm.plot(np.degrees(fit), t, "-", color="k", lw=1,
                         label="TMA fitted" if i == 0 else None)
        axm.set_xlim(0, 180)
        axm.invert_yaxis()
        axm.set_xlabel("cone angle (deg, 0 = forward end-fire)")
        axm.set_ylabel("time (s)")
        axm.grid(True, alpha=0.3)
        axm.legend(fontsize=8)
        axm.set_title("each track's cone angles: measured vs fitted (time runs down)")
    return finish(fig, new, LAYOUT)
