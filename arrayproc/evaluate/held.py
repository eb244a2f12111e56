"""How much of the last two thirds of a simulated run each source is held by one confirmed
track, from a multi-target ``tracks`` file and the truth of its recording.

For each source (the tow ship included: it is a real source in the data), over the scans of
the window (t ≥ t_end − ⅔·(t_end − t_start), every scan of the tracks file, detected or not):
its principal track is the confirmed track within ``gate_deg`` of its true cone angle
(:func:`arrayproc.io.truth.cone_angles`) at the most scans; "held" is the share of the
window's scans at which that track is confirmed and within the gate. A confirmed track (at
least 3 confirmed points) within the gate of no source at more than half of its confirmed
points is false; "extra" counts the confirmed tracks, other than the principal, that follow
a source at more than half of their points (duplicates).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from arrayproc.config import resolve_beside
from arrayproc.io import truth as truth_mod
from arrayproc.io.products import read_products
from arrayproc.io.recording import Recording
from arrayproc.io.text import as_text
from arrayproc.track.manage.tracks import status_names

__all__ = ["held_last_two_thirds"]


def held_last_two_thirds(path: str, gate_deg: float = 5.0) -> dict[str, Any]:
    """Per source: held share of the window, principal track id, extra tracks; false
    confirmed tracks (module doc).

    Parameters
    ----------
    path : str
        Tracks file of the multi-target tracker (its root ``recording`` names the simulated
        recording with ``/truth``).
    gate_deg : float
        Cone-angle gate, deg.

    Returns
    -------
    dict
        ``sources`` (names), ``held`` (share per source), ``principal`` (track id, −1 none),
        ``extra`` (list of track ids per source), ``false_tracks``, ``n_confirmed``,
        ``window_s`` ([start, end] s).
    """
    prod = read_products(path)
    g = prod["tracks"]
    rec = resolve_beside(as_text(prod["/"].get("recording", "")), path)
    tid = np.asarray(g["track_id"], np.int64)
    conf = status_names(g["status"]) == "confirmed"
    t = np.asarray(g["time"], float)
    cone = np.asarray(g["cone_deg"], float)
    times = np.unique(t)
    with Recording(rec, require_geometry=False) as r:
        truth = truth_mod.cone_angles(r, times)
    names = sorted(truth)
    t0 = times[-1] - 2.0 / 3.0 * (times[-1] - times[0])
    win = times >= t0
    ti = np.searchsorted(times, t)
    near = {n: conf & (np.abs(cone - truth[n][ti]) <= gate_deg) for n in names}
    out: dict[str, Any] = {"sources": names, "held": [], "principal": [], "extra": [],
                           "false_tracks": []}
    ids = np.unique(tid[conf])
    for n in names:
        inwin = near[n] & win[ti]
        counts = {int(i): int(np.unique(ti[inwin & (tid == i)]).size) for i in ids}
        best = max(counts, key=counts.get) if counts and max(counts.values()) else -1
        out["principal"].append(best)
        out["held"].append(round(counts.get(best, 0) / int(win.sum()), 3))
        extra = [int(i) for i in ids if i != best
                 and (near[n] & (tid == i)).sum() > 0.5 * (conf & (tid == i)).sum()]
        out["extra"].append(extra)
    for i in ids:
        mine = conf & (tid == i)
        hit = np.zeros(mine.sum(), bool)
        for n in names:
            hit |= near[n][mine]
        if mine.sum() >= 3 and hit.mean() <= 0.5:
            out["false_tracks"].append(int(i))
    out["n_confirmed"] = int(ids.size)
    out["window_s"] = [round(float(t0), 1), round(float(times[-1]), 1)]
    return out
