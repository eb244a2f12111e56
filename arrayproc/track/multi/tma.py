"""The TMA of each multi-target bearing track: its rows' port/starboard bearings through the
configured single-target filter (:func:`arrayproc.track.single.track_bearings`, the hypothesis
bank with left-right resolution)."""

from __future__ import annotations

from typing import Any

import numpy as np

from arrayproc.geo.nav import Nav
from arrayproc.track.manage.tracks import Track

__all__ = ["tma_track", "resolved_side"]


def resolved_side(side: np.ndarray | None, rows: np.ndarray) -> np.ndarray | None:
    """The sides (+1 starboard, −1 port) of the rows ``rows`` when every one was resolved by
    port/starboard-resolving beams (``bearings`` column ``side``, whose resolved rows hold the
    one true bearing in both bearing columns), else None (ambiguous: mirror hypotheses)."""
    if side is None:
        return None
    s = np.asarray(side, float)[rows]
    return s if s.size and np.all(np.abs(s) == 1.0) else None


def tma_track(tr: Track, b: dict[str, np.ndarray], nav: Nav, tma_cfg: dict[str, Any],
              by_side: bool = False) -> dict[str, np.ndarray] | None:
    """TMA of one cone track: its rows' port/starboard bearings through the configured filter
    (UKF with left-right resolution by default) from its first row — the two hypotheses fed
    by side (``by_side``, starboard and port members) or by continuity
    (:func:`~arrayproc.track.single.assign_by_continuity`), or one hypothesis when every row
    was resolved to its side by the beams (:func:`resolved_side`); between rows (coasting)
    the state is predicted with constant velocity. Returns the rows to write, or None when the
    track has fewer than two rows."""
    from arrayproc.track.single import assign_by_continuity, ownship_states, track_bearings

    h = tr.arrays()
    rows = tr.meta["rows"]
    used = rows >= 0
    if used.sum() < 2:
        return None
    r = rows[used]
    t = b["time"][r]
    own, hd = ownship_states(nav, t)
    port = np.deg2rad(b["bearing_port_deg"][r])
    stbd = np.deg2rad(b["bearing_stbd_deg"][r])
    side = resolved_side(b.get("side"), r)
    if side is not None:  # every row resolved to its side by the beams: no mirror hypothesis
        zs = stbd[:, None]
    elif tma_cfg["lr"] and by_side:
        zs = np.stack([stbd, port], 1)  # hypothesis 0 starboard, 1 port, as in the cone track
    elif tma_cfg["lr"]:
        zs = assign_by_continuity(port, stbd)
    else:
        zs = (port if tma_cfg["side"] == "port" else stbd)[:, None]
    zs = (zs + np.pi) % (2 * np.pi) - np.pi
    xs, Ps, ws, status = track_bearings(t, zs, own, tma_cfg, heading=hd)
    if status & 4:  # diverged: keep the rows before
        ok = np.flatnonzero(np.any(ws > 0, axis=1))
        n_ok = int(ok.max()) + 1 if ok.size else 0
        if n_ok < 2:
            return None
    else:
        n_ok = t.size
    absx = xs[:n_ok, :4] + own[:n_ok]
    Pk = Ps[:n_ok, :4, :4]
    if zs.shape[1] == 2:
        on_stbd = np.isclose(np.cos(zs[:n_ok, 0] - stbd[:n_ok]), 1.0)
        side_w = np.where(on_stbd, ws[:n_ok, 0], ws[:n_ok, 1])
    elif side is not None:
        side_w = (side[:n_ok] > 0).astype(float)
    else:
        side_w = np.full(n_ok, 1.0 if tma_cfg["side"] == "starboard" else 0.0)
    # every history point: the TMA state at its row, or predicted from the latest row
    th = h["time"]
    last = np.searchsorted(t[:n_ok], th, side="right") - 1
    keep = last >= 0
    th, last = th[keep], last[keep]
    dt = th - t[:n_ok][last]
    X = absx[last].copy()
    X[:, :2] += dt[:, None] * X[:, 2:]
    F = np.broadcast_to(np.eye(4), (dt.size, 4, 4)).copy()
    F[:, 0, 2] = F[:, 1, 3] = dt
    P = F @ Pk[last] @ F.transpose(0, 2, 1)
    own_h, _ = ownship_states(nav, th)
    return {"time": th, "x": X[:, 0], "y": X[:, 1], "vx": X[:, 2], "vy": X[:, 3], "cov": P,
            "status": h["status"][keep], "side_weight": side_w[last],
            "own_x": own_h[:, 0], "own_y": own_h[:, 1], "cone_deg": tr.meta["cone"][keep],
            "sigma_cone_deg": tr.meta["sigma_cone"][keep], "row": rows[keep]}
