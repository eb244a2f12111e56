"""Scores of the several-source chain run end to end (``simulate → process → track``) and of
its run on a real recording: positions and tracks against the simulation's ``/truth``, the
snapshots or events with more than one source, and a plan/side plot of the sources.

Used by ``scripts/validate_multi_source.py``; truth is read from the recording (``/truth/
sources/<name>/{time, position}``, positions interpolated linearly in time).
"""

from __future__ import annotations

from typing import Any

import h5py
import numpy as np

from arrayproc.io.products import read_products
from arrayproc.io.schema import groups_of_kind

__all__ = ["truth_tracks", "score_positions", "score_tracks", "multi_source_events",
           "plot_sources"]


def truth_tracks(rec_path: str) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Every simulated source's truth: name → (time (n,) s, position (n, 2) m)."""
    with h5py.File(rec_path, "r") as f:
        if "truth/sources" not in f:
            return {}
        return {n: (f[f"truth/sources/{n}/time"][:], f[f"truth/sources/{n}/position"][:])
                for n in f["truth/sources"]}


def _at(truth: dict, t: np.ndarray) -> np.ndarray:
    """Truth positions (n_src, len(t), 2) at times t."""
    return np.stack([np.stack([np.interp(t, tt, p[:, i]) for i in range(2)], -1)
                     for tt, p in truth.values()])


def _group(prod: Any, kind: str) -> dict:
    names = groups_of_kind(prod, kind)
    return prod[names[0]] if names else {}


def score_positions(rec_path: str, products_path: str, good_m: float = 1.0) -> dict:
    """Each localised position matched to the nearest true source (horizontal distance):
    per source the count, the median and RMS horizontal error (m), the fraction within
    ``good_m`` and how often each ``source`` index (0 strongest) was it."""
    truth = truth_tracks(rec_path)
    g = _group(read_products(products_path), "positions")
    t = np.asarray(g.get("time", []), float)
    if t.size == 0:
        return {n: {"localised": 0} for n in truth}
    xy = np.stack([g["x"], g["y"]], -1)
    src = np.asarray(g["source"]) if "source" in g else np.zeros(t.size, np.int64)
    e = np.linalg.norm(_at(truth, t) - xy[None], axis=-1)          # (n_src, n)
    j = np.argmin(e, axis=0)
    out = {}
    for q, name in enumerate(truth):
        m = j == q
        ee = e[q, m]
        out[name] = {"localised": int(m.sum()),
                     "median_err_m": float(np.median(ee)) if ee.size else None,
                     "rms_err_m": float(np.sqrt(np.mean(ee**2))) if ee.size else None,
                     f"within_{good_m:g}m": float(np.mean(ee < good_m)) if ee.size else None,
                     "source_index": np.bincount(src[m], minlength=2).tolist()}
    return out


def score_tracks(rec_path: str, tracks_path: str) -> dict:
    """Confirmed tracks against the truth: per track its span, the source it follows
    (nearest on most points) and its median error; per source the tracks that follow it
    and the fraction of the run the longest covers."""
    truth = truth_tracks(rec_path)
    g = _group(read_products(tracks_path), "tracks")
    ids, st = np.asarray(g["track_id"]), np.asarray(g["status"])
    t = np.asarray(g["time"], float)
    xy = np.stack([g["x"], g["y"]], -1)
    span = float(t.max() - t.min()) if t.size else 0.0
    names = list(truth)
    tracks = []
    for i in np.unique(ids[st == 1]):
        m = (ids == i) & (st == 1)
        e = np.linalg.norm(_at(truth, t[m]) - xy[m][None], axis=-1)
        q = int(np.bincount(np.argmin(e, axis=0), minlength=len(names)).argmax())
        tracks.append({"track_id": int(i), "source": names[q], "t0": float(t[m][0]),
                       "t1": float(t[m][-1]), "points": int(m.sum()),
                       "median_err_m": float(np.median(e[q]))})
    per = {}
    for name in names:
        mine = [tr for tr in tracks if tr["source"] == name]
        longest = max((tr["t1"] - tr["t0"] for tr in mine), default=0.0)
        per[name] = {"tracks": [tr["track_id"] for tr in mine],
                     "longest_cover": longest / span if span else 0.0}
    return {"all_tracks": int(np.unique(ids).size), "confirmed": tracks, "per_source": per}


def multi_source_events(products_path: str) -> dict:
    """Snapshots or events with more than one source row in the ``delays`` product, and how
    many of those sources were localised (``positions`` rows at the same time)."""
    prod = read_products(products_path)
    d, p = _group(prod, "delays"), _group(prod, "positions")
    t = np.asarray(d.get("time", []), float)
    times, counts = np.unique(t, return_counts=True)
    multi = times[counts > 1]
    tp = np.asarray(p.get("time", []), float)
    loc = np.array([int(np.sum(tp == x)) for x in multi], np.int64)
    clo = np.asarray(d.get("closure", np.ones(t.size)), float)
    cor = np.asarray(d.get("corr", np.ones((t.size, 1))), float)
    rows = [{"time": float(x), "sources": int(c), "localised": int(n),
             "closure": [round(float(v), 2) for v in clo[t == x]],
             "median_corr": [round(float(np.median(r)), 2) for r in cor[t == x]]}
            for x, c, n in zip(multi, counts[counts > 1], loc, strict=True)]
    return {"events": int(times.size), "with_several_sources": int(multi.size),
            "with_several_localised": int(np.sum(loc > 1)), "rows": rows}


def plot_sources(products_path: str, out_png: str, elements: np.ndarray | None = None,
                 truth: dict | None = None, title: str = "", span: float | None = None
                 ) -> None:
    """Plan (x east, y north) and side (x east, depth down) views of the localised sources:
    source 0 (strongest) as dots, further sources as squares, the sources of one event joined
    by a thin line, hydrophones as triangles, truth tracks as thick green lines; axes in m,
    ``span`` the half-width of the views around the array (default: fits 90 % of the
    positions, at least 3 m; the title counts those outside)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    g = _group(read_products(products_path), "positions")
    p = np.stack([g["x"], g["y"], g["z"]], -1) if "x" in g else np.zeros((0, 3))
    t = np.asarray(g.get("time", []), float)
    src = np.asarray(g["source"]) if "source" in g else np.zeros(t.size, np.int64)
    centre = elements.mean(axis=0) if elements is not None else np.zeros(3)
    far = np.max(np.abs(p - centre), axis=1)
    if span is None:
        span = max(3.0, 1.2 * float(np.percentile(far, 90))) if far.size else 5.0
    n_out = int(np.sum(far > span))
    fig, axes = plt.subplots(1, 2, figsize=(12, 6), layout="constrained")
    for ax, (i, j), lab in ((axes[0], (0, 1), "y north (m)"),
                            (axes[1], (0, 2), "z depth (m, down)")):
        for x in np.unique(t[src > 0]):
            m = t == x
            ax.plot(p[m, i], p[m, j], color="0.7", lw=0.5, alpha=0.5, zorder=1)
        if truth and j == 1:
            for (n, (_, xy)), col in zip(truth.items(), ("tab:green", "tab:cyan", "tab:olive"),
                                         strict=False):
                ax.plot(xy[:, 0], xy[:, 1], color=col, lw=3, alpha=0.9, zorder=5,
                        label=f"truth {n}")
        sc = None
        for s, mk in ((0, "o"), (1, "s"), (2, "D")):
            m = src == s
            if m.any():
                sc = ax.scatter(p[m, i], p[m, j], c=t[m], cmap="plasma", marker=mk, s=22,
                                vmin=t.min(), vmax=t.max(), zorder=3,
                                label=f"source {s}" + (" (strongest)" if s == 0 else ""))
        if elements is not None:
            ax.scatter(elements[:, i], elements[:, j], marker="^", c="k", s=40, zorder=4,
                       label="hydrophones")
        ax.set_xlim(centre[i] - span, centre[i] + span)
        ax.set_ylim(centre[j] - span, centre[j] + span)
        ax.set_xlabel("x east (m)")
        ax.set_ylabel(lab)
        ax.set_aspect("equal")
        ax.grid(True, alpha=0.3)
    axes[1].invert_yaxis()
    axes[0].set_title("plan view")
    axes[1].set_title("side view (looking north)")
    axes[0].legend(loc="best", fontsize=8)
    if sc is not None:
        fig.colorbar(sc, ax=axes, shrink=0.8).set_label("time (s since recording start)")
    more = f", {n_out} outside the view" if n_out else ""
    fig.suptitle((title or "localised sources") + f"\n{p.shape[0]} positions{more}",
                 fontsize=10)
    fig.savefig(out_png, dpi=110)
    plt.close(fig)
