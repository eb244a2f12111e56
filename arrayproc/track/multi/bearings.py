"""Bearing scans of a towed line array tracked as cone tracks: rows grouped into scans and
merged, then one track manager with mirrored true-bearing hypotheses
(:mod:`arrayproc.track.manage.mirrored`) or one cone / cone-rate filter per track."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from arrayproc.errors import ConfigError
from arrayproc.geo.nav import Nav
from arrayproc.track.filters.stacked import StackedEKF
from arrayproc.track.manage.tracks import Track
from arrayproc.track.models.motion import ConstantVelocity
from arrayproc.track.models.position import ConeAngle
from arrayproc.track.multi.compose import compose_manager
from arrayproc.track.state import Context

__all__ = ["bearing_scans", "cone_filter", "track_cones"]

def bearing_scans(time: np.ndarray, cone: np.ndarray, score: np.ndarray, merge_deg: float
                  ) -> list[tuple[float, np.ndarray, np.ndarray]]:
    """Group bearing rows into scans (one per distinct time) and merge the rows of a scan whose
    cone angles lie within ``merge_deg`` of their neighbours into one measurement, the row with
    the highest ``score``.

    Parameters
    ----------
    time, cone, score : ndarray (n,)
        Row times (s), cone angles (deg) and strengths (dB).
    merge_deg : float
        Largest gap (deg) inside one cluster.

    Returns
    -------
    list of (t, Z, rows)
        Scan time, cone angles Z (m, 1) deg and the products row of each measurement (m,).
    """
    order = np.lexsort((cone, time))
    out = []
    if order.size == 0:
        return out
    ts = time[order]
    cuts = np.flatnonzero(np.diff(ts) != 0) + 1
    for seg in np.split(order, cuts):
        c = cone[seg]
        groups = np.split(seg, np.flatnonzero(np.diff(c) > merge_deg) + 1)
        rows = np.array([g[np.argmax(score[g])] for g in groups], np.int64)
        out.append((float(time[seg[0]]), cone[rows][:, None], rows))
    return out



def cone_filter(bcfg: dict[str, Any]) -> StackedEKF:
    """The bearing / bearing-rate (cone, cone-rate) filter: CV with q_cone, R from σ_cone at
    broadside widened by 1 / sin θ (thesis eq. 2.9) down to ``min_sigma_sin``."""
    return StackedEKF(ConstantVelocity(q1=float(bcfg["q_cone"]), axes=1),
                      ConeAngle(sigma_deg=float(bcfg["sigma_cone_deg"]),
                                min_sin=float(bcfg["min_sigma_sin"])))


def track_cones(scans: list[tuple[float, np.ndarray, np.ndarray]], cfg: dict[str, Any],
                nav: Nav | None = None) -> list[Track]:
    """Run the track manager over bearing scans (Z (m, 3): cone, port and starboard bearings,
    deg). ``bearing.space = "cone"``: one cone / cone-rate filter per track (the context of
    each scan is its Z, the noise depends on the cone angle); ``"bearing"``: mirrored
    true-bearing hypotheses (:mod:`arrayproc.track.manage.mirrored`, needs ``nav``).
    ``meta['rows']`` of every track holds the products row of each history point (−1:
    coasted), ``meta['cone']``, ``meta['sigma_cone']`` and ``meta['stbd_weight']`` its cone
    angle (deg), σ and starboard weight (NaN in cone space)."""
    from arrayproc.track.manage.mirrored import mirrored_bank, mirrored_cone, mirrored_initial
    from arrayproc.track.single import ownship_states

    b = cfg["bearing"]
    s0, sr, smin = float(b["sigma_cone_deg"]), float(b["sigma_rate_deg_s"]), \
        float(b["min_sigma_sin"])
    mirrored = b["space"] == "bearing"
    if mirrored and nav is None:
        raise ConfigError("tracker.bearing.space = 'bearing' needs the array's navigation")
    if mirrored:
        filt: Any = mirrored_bank(float(b["q_bearing"]), s0, smin)

        def init(Z: np.ndarray, t: float, ctx: Any, j: int) -> tuple[np.ndarray, ...]:
            return mirrored_initial(Z, j, s0, smin, sr)
        pos: tuple[int, ...] = (0, 1, 2, 3)  # rates too: mirror pairs cross in cone
        ts = np.array([t for t, _Z, _r in scans])
        _own, hd = ownship_states(nav, ts)
        rate = np.abs(np.gradient(np.unwrap(hd), ts)) if ts.size > 1 else np.zeros(1)
        qmul = 1.0 + (np.degrees(rate) / float(b["turn_ref_deg_s"])) ** 2
    else:
        filt = cone_filter(b)

        def init(Z: np.ndarray, t: float, ctx: Any, j: int) -> tuple[np.ndarray, np.ndarray]:
            s = s0 / max(math.sin(math.radians(float(Z[j, 0]))), smin)
            return np.array([Z[j, 0], 0.0]), np.diag([s * s, sr * sr])
        pos = (0,)

    mgr = compose_manager(cfg, filt, init, pos, float(b["merge_d2"]))
    for k, (t, Z, _rows) in enumerate(scans):
        if mirrored:
            mgr.step(t, Z, Context(np.zeros(4), q_scale=float(qmul[k])))
        else:
            mgr.step(t, Z[:, :1], None)
    scan_rows = {t: r for t, _Z, r in scans}
    for tr in mgr.tracks:
        h = tr.arrays()
        rows = np.full(h["meas"].size, -1, np.int64)
        # history point k was made at scan time h["time"][k]
        for k, (tk, j) in enumerate(zip(h["time"], h["meas"], strict=True)):
            if j >= 0:
                rows[k] = scan_rows[float(tk)][j]
        tr.meta["rows"] = rows
        if mirrored:
            _o, hh = ownship_states(nav, h["time"])
            c, sc, ws = mirrored_cone(filt, h["x"], h["P"], h["logw"], np.degrees(hh))
        else:
            c, sc = h["x"][:, 0], np.sqrt(np.clip(h["P"][:, 0, 0], 0, None))
            ws = np.full(c.size, np.nan)
        tr.meta["cone"], tr.meta["sigma_cone"], tr.meta["stbd_weight"] = c, sc, ws
    return mgr.tracks
