"""Active contacts tracked in Cartesian coordinates: scans per ping, the EKF with the
bearing-range-range-rate model (:mod:`arrayproc.track.models.bearing_range_rate`) in world
coordinates, and the rule against twin births of a line array's mirror bearing."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from arrayproc.geo.nav import Nav
from arrayproc.track.filters.stacked import StackedEKF
from arrayproc.track.manage.manager import TrackManager
from arrayproc.track.manage.tracks import Track
from arrayproc.track.models.frame import ObserverRelative
from arrayproc.track.models.motion import ConstantVelocity
from arrayproc.track.multi.compose import compose_manager
from arrayproc.track.state import Context

__all__ = ["contact_scans", "drop_twin_births", "contacts_manager"]

def contact_scans(c: dict[str, np.ndarray], nav: Nav, mirror: bool, sound_speed: float = 1500.0,
                  keep: np.ndarray | None = None
                  ) -> list[tuple[float, np.ndarray, np.ndarray, np.ndarray]]:
    """Scans of contacts: Z (m, 3) [bearing rad, range m, range rate m/s], products rows (m,),
    and the ownship state (4,). With ``mirror`` a contact whose port and starboard bearings
    differ enters twice.

    Without a ``ping`` column, one scan per distinct ``time``. With one (the active chain's
    contacts, whose ``time`` is each echo's reception time t_rx, spread over the ping's
    receive window), one scan per ping at the transmission time t_tx, estimated as the median
    of t_rx − 2r/c over the ping's contacts (exact up to the bistatic offset, |p|/c). An echo
    describes the geometry at its scattering time t_sc = t_rx − r/c; its range is carried
    back to the scan time along its own range rate, r − ṙ (t_sc − t_tx) (first order; the
    bearing changes by at most the relative tangential speed over c, 0.1° at 3 m/s, and is
    left as measured). The ownship state is taken at t_tx.

    Parameters
    ----------
    c : dict of ndarray
        Columns ``time``, ``range_m``, ``bearing_port_deg``, ``bearing_stbd_deg``,
        ``range_rate_mps`` and optionally ``ping``.
    nav : Nav
        The array's navigation.
    mirror : bool
        Enter both candidate bearings of a line array's contact.
    sound_speed : float
        c (m/s) for the travel times of ping-grouped contacts.
    keep : ndarray of bool, optional
        Rows that enter as measurements (e.g. those flagged ``moving``); every row still
        defines its scan and its time, so a ping without a kept row is an empty scan (a miss
        for every track).

    Returns
    -------
    list of (t, Z, rows, own)
        Scan time (s), measurements (m, 3), products row of each measurement (m,), ownship
        state [x, y, ẋ, ẏ] at t.
    """
    from arrayproc.track.single import ownship_states

    t = c["time"]
    by_ping = "ping" in c
    key = c["ping"] if by_ping else t
    out = []
    order = np.argsort(key, kind="stable")
    cuts = np.flatnonzero(np.diff(key[order]) != 0) + 1
    for seg in np.split(order, cuts):
        if seg.size == 0:
            continue
        rng = np.asarray(c["range_m"][seg], float).copy()
        rdot = c["range_rate_mps"][seg]
        if by_ping:
            ts = float(np.median(t[seg] - 2.0 * rng / sound_speed))
            rng -= rdot * (t[seg] - rng / sound_speed - ts)
        else:
            ts = float(t[seg[0]])
        own, _ = ownship_states(nav, np.array([ts]))
        zs, rows = [], []
        for k, i in enumerate(seg):
            if keep is not None and not keep[i]:
                continue
            bp, bs = c["bearing_port_deg"][i], c["bearing_stbd_deg"][i]
            sides = [bs] if (not mirror or abs(((bp - bs + 180) % 360) - 180) < 1e-6) \
                else [bp, bs]
            for bb in sides:
                zs.append([math.radians(bb), rng[k], rdot[k]])
                rows.append(i)
        out.append((ts, np.array(zs, float).reshape(-1, 3), np.array(rows, np.int64),
                    own[0]))
    return out


def drop_twin_births(tracks: list[Track], n_before: int, t: float, rows: np.ndarray) -> None:
    """Remove, in place, the tracks born in the scan at ``t`` (``tracks[n_before:]``) from a
    measurement whose twin — the other candidate bearing of the same contact, i.e. the same
    products row — updated a track in that scan: the echo is already explained, and its
    mirror image would start a ghost on the far side of a line array after every turn.

    Parameters
    ----------
    tracks : list of Track
        The manager's tracks after the scan.
    n_before : int
        Number of tracks before the scan.
    t : float
        Scan time (s).
    rows : ndarray (m,)
        Products row of each measurement of the scan.
    """
    used = {int(rows[tr.history[-1].meas]) for tr in tracks[:n_before]
            if tr.history and tr.history[-1].time == t and tr.history[-1].meas >= 0}
    if used:
        tracks[n_before:] = [tr for tr in tracks[n_before:]
                             if int(rows[tr.history[0].meas]) not in used]


def contacts_manager(cfg: dict[str, Any]) -> TrackManager:
    """Track manager for contacts: EKF with the bearing-range-range-rate model."""
    from arrayproc.track.models.bearing_range_rate import BearingRangeRate

    cc = cfg["contacts"]
    model = BearingRangeRate.from_degrees(cc["sigma_bearing_deg"], cc["sigma_range_m"],
                                          cc["sigma_range_rate_mps"])
    filt = StackedEKF(ConstantVelocity(q1=float(cc["q"]), axes=2), ObserverRelative(model))
    sv = float(cc["sigma_speed_mps"])

    def init(Z: np.ndarray, t: float, ctx: Context, j: int) -> tuple[np.ndarray, np.ndarray]:
        return model.inverse(Z[j], ctx.own, sv)

    return compose_manager(cfg, filt, init, (0, 1))
