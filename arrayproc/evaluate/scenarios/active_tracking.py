"""The multi-target tracker on the active scenario's contacts, scored against ``/truth``.

Contacts (:func:`score_contacts`): the submarine's echo detected per ping (range within 30 m,
one of the two candidate bearings within 3° of the truth), clutter echoes detected and flagged
moving, false alarms (contacts within 60 m and 5° of no echo), and how many of each pass the
tracker's input filter (``moving_only``, ``min_snr_db``).

Tracks (:func:`score_tracks`): the share of the pings with a submarine contact during which
its principal confirmed track holds it (within ``gate`` m,
:func:`arrayproc.evaluate.metrics.track_scores`), breaks, position / velocity / range-rate
errors of that track; every other confirmed track with its class (the submarine's
port/starboard mirror image, a clutter scatterer or its image, or noise false alarms), its
confirmed life in pings and its hits (:func:`classify_other_tracks`); GOSPA against the
submarine (:func:`arrayproc.evaluate.metrics.over_time`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from arrayproc.evaluate.metrics import over_time, track_scores
from arrayproc.io.products import read_products
from arrayproc.io.text import as_text
from arrayproc.io.truth import active_scene
from arrayproc.track.manage.tracks import status_names
from arrayproc.track.multi import split_config

__all__ = ["ActiveTruth", "read_truth", "score_contacts", "score_tracks",
           "classify_other_tracks", "evaluate", "stats"]


def _interp(t: np.ndarray, tt: np.ndarray, v: np.ndarray) -> np.ndarray:
    return np.stack([np.interp(t, tt, v[:, i]) for i in range(v.shape[1])], -1)


def _wrap(a: np.ndarray) -> np.ndarray:
    return (a + 180.0) % 360.0 - 180.0


def _mirror(own_xy: np.ndarray, heading_deg: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Mirror image of points p (n, 2) across the array's axis through own_xy (n, 2)."""
    a = np.stack([np.sin(np.radians(heading_deg)), np.cos(np.radians(heading_deg))], -1)
    d = p - own_xy
    return own_xy + 2 * np.sum(d * a, -1, keepdims=True) * a - d


@dataclass
class ActiveTruth:
    """The truth of an active recording the scores need: sound speed, ping times, the
    submarine's and the ownship's tracks, the scatterers and the echoes."""

    c: float
    ping_t: np.ndarray
    sub: dict
    own: dict
    names: list
    kinds: list
    sc_pos: np.ndarray
    echoes: dict

    @property
    def i_sub(self) -> int:
        return self.names.index("submarine")

    @property
    def clutter(self) -> np.ndarray:
        return np.array([k == "clutter" for k in self.kinds])

    def own_at(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Ownship position (n, 2) m, velocity (n, 2) m/s and heading (n,) deg at times t."""
        own = self.own
        hd_unw = np.unwrap(np.radians(own["heading"]))
        return (_interp(t, own["time"], own["position"]),
                _interp(t, own["time"], own["velocity"]),
                np.degrees(np.interp(t, own["time"], hd_unw)))

    def sub_at(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Submarine position (n, 2) m and velocity (n, 2) m/s at times t."""
        sub = self.sub
        return _interp(t, sub["time"], sub["position"]), _interp(t, sub["time"],
                                                                 sub["velocity"])


def read_truth(rec: Path) -> ActiveTruth:
    """:class:`ActiveTruth` of a simulated active recording
    (:func:`arrayproc.io.truth.active_scene`)."""
    t = active_scene(rec)
    return ActiveTruth(t["sound_speed"], t["ping_time"], t["submarine"], t["ownship"],
                       t["names"], t["kinds"], t["position0"], t["echoes"])


def score_contacts(truth: ActiveTruth, prod: Path, tracker_cfg: str) -> tuple[dict, dict]:
    """Contacts against the echoes' truth (module docstring).

    Returns
    -------
    (dict, dict)
        The contact figures, and ``{"sub_det" (n_ping,) bool}`` for the track scores.
    """
    c, ping_t, echoes = truth.c, truth.ping_t, truth.echoes
    sc_pos, i_sub, clutter = truth.sc_pos, truth.i_sub, truth.clutter
    sub_at, own_at = truth.sub_at, truth.own_at
    pg = read_products(str(prod))
    cg = next(g for n, g in pg.items() if n != "/" and as_text(g.get("kind")) == "contacts")
    ct = {k: np.asarray(cg[k]) for k in ("ping", "time", "range_m", "bearing_port_deg",
                                         "bearing_stbd_deg", "range_rate_mps", "moving",
                                         "snr_db", "absolute_doppler_mps")}
    n_ping = ping_t.size
    e_pos = np.where(echoes["target"] == i_sub, 0, 1)
    # true bearing of every echo: scatterer at its scattering time from the array at reception
    t_sc = echoes["time"] - echoes["range_m"] / c
    sp = np.where(e_pos[:, None] == 0, sub_at(t_sc)[0], sc_pos[echoes["target"]])
    o_rx = own_at(echoes["time"])[0]
    e_brg = np.degrees(np.arctan2(sp[:, 0] - o_rx[:, 0], sp[:, 1] - o_rx[:, 1]))
    matched_echo = np.full(ct["time"].size, -1)
    loose = np.zeros(ct["time"].size, bool)
    sub_det = np.zeros(n_ping, bool)
    sub_contact_rows = []
    for k in range(n_ping):
        rows = np.flatnonzero(ct["ping"] == k)
        ek = np.flatnonzero(echoes["ping"] == k)
        if rows.size == 0 or ek.size == 0:
            continue
        dr = np.abs(ct["range_m"][rows][:, None] - echoes["range_m"][ek][None])
        db = np.minimum(np.abs(_wrap(ct["bearing_port_deg"][rows][:, None] - e_brg[ek][None])),
                        np.abs(_wrap(ct["bearing_stbd_deg"][rows][:, None] - e_brg[ek][None])))
        tight = (dr < 30.0) & (db < 3.0)
        loose[rows] = ((dr < 60.0) & (db < 5.0)).any(1)
        for a, r in enumerate(rows):
            if tight[a].any():
                matched_echo[r] = ek[np.argmin(np.where(tight[a], dr[a], np.inf))]
        hits = rows[matched_echo[rows] >= 0]
        s_hits = hits[echoes["target"][matched_echo[hits]] == i_sub]
        if s_hits.size:
            sub_det[k] = True
            sub_contact_rows.append(int(s_hits[np.argmax(ct["snr_db"][s_hits])]))
    sr = np.array(sub_contact_rows, np.int64)
    se = matched_echo[sr]
    cl_e = np.flatnonzero(clutter[echoes["target"]])
    cl_hit_rows = np.flatnonzero((matched_echo >= 0)
                                 & clutter[echoes["target"][np.maximum(matched_echo, 0)]])
    cl_echo_detected = np.unique(matched_echo[cl_hit_rows])
    fa = ~loose
    cfg, _tma = split_config(tracker_cfg)
    cc = cfg["contacts"]
    enters = np.ones(ct["time"].size, bool)
    if cc["moving_only"]:
        enters &= ct["moving"].astype(bool)
    if cc["min_snr_db"] > 0:
        enters &= ct["snr_db"] >= cc["min_snr_db"]
    contacts = {
        "entering_tracker": int(enters.sum()),
        "entering_submarine": int(enters[sr].sum()),
        "entering_clutter": int(enters[cl_hit_rows].sum()),
        "entering_false_alarms": int(enters[fa].sum()),
        "n_contacts": int(ct["time"].size), "n_pings": int(n_ping),
        "submarine_detected_pings": int(sub_det.sum()),
        "submarine_range_error_m": stats(ct["range_m"][sr] - echoes["range_m"][se]),
        "submarine_range_rate_error_mps": stats(ct["range_rate_mps"][sr]
                                                 - echoes["range_rate_mps"][se]),
        "submarine_snr_db": stats(ct["snr_db"][sr]),
        "submarine_moving_pings": int(ct["moving"][sr].astype(bool).sum()),
        "clutter_echoes": int(cl_e.size),
        "clutter_echoes_detected": int(cl_echo_detected.size),
        "clutter_contacts": int(cl_hit_rows.size),
        "clutter_contacts_moving": int(ct["moving"][cl_hit_rows].astype(bool).sum()),
        "false_alarms": int(fa.sum()),
        "false_alarms_per_ping": round(float(fa.sum()) / max(1, n_ping), 1),
        "false_alarms_moving": int(ct["moving"][fa].astype(bool).sum()),
        "false_alarm_snr_db": stats(ct["snr_db"][fa]),
    }

    return contacts, {"sub_det": sub_det, "snr_db": ct["snr_db"]}


def score_tracks(truth: ActiveTruth, tracks: Path, sub_det: np.ndarray, contact_snr_db:
                 np.ndarray, gate: float, cutoff: float) -> tuple[dict, dict]:
    """The submarine's principal track, the other confirmed tracks and GOSPA (module
    docstring); the arrays the figures need as the second value."""
    ping_t = truth.ping_t
    n_ping = ping_t.size
    sub_at, own_at = truth.sub_at, truth.own_at
    tg = read_products(str(tracks))["tracks"]
    tid = np.asarray(tg["track_id"], np.int64)
    st = status_names(tg["status"])
    tt = np.asarray(tg["time"], float)
    xy = np.stack([np.asarray(tg["x"], float), np.asarray(tg["y"], float)], 1)
    vxy = np.stack([np.asarray(tg["vx"], float), np.asarray(tg["vy"], float)], 1)
    row = np.asarray(tg["row"], np.int64)
    scan_t = np.unique(tt)
    # scan times are the estimated transmissions: map each to its ping
    ki = np.argmin(np.abs(scan_t[:, None] - ping_t[None]), axis=1)
    scan_err = float(np.abs(scan_t - ping_t[ki]).max()) if scan_t.size else float("nan")
    ping_of = dict(zip(scan_t.tolist(), ki.tolist(), strict=True))
    pk = np.array([ping_of[v] for v in tt], np.int64)
    conf = st == "confirmed"
    s_xy, s_v = sub_at(ping_t)
    sub_truth = s_xy[None]
    ids = np.unique(tid[conf])
    tix = {int(i): pk[conf & (tid == i)] for i in ids}
    tv = {int(i): xy[conf & (tid == i)] for i in ids}
    sc = track_scores(sub_truth, sub_det[None], tix, tv, gate)
    pr = int(sc.principal[0])
    o_xy, o_v, o_hd = own_at(tt)
    s_row_xy, s_row_v = sub_at(tt)
    mirror_sub = _mirror(o_xy, o_hd, s_row_xy)
    sub_track: dict = {"principal": pr, "held": round(float(sc.held[0]), 3),
                       "breaks": int(sc.breaks[0]),
                       "n_detected_pings": int(sc.n_detected[0])}
    if pr >= 0:
        m = conf & (tid == pr)
        lab = sc.labels[pr]
        mm = np.flatnonzero(m)[lab == 0]
        d = xy[mm] - s_row_xy[mm]
        los = s_row_xy[mm] - o_xy[mm]
        u = los / np.linalg.norm(los, axis=1, keepdims=True)
        rr_trk = np.sum(u * (vxy[mm] - o_v[mm]), 1)
        rr_true = np.sum(u * (s_row_v[mm] - o_v[mm]), 1)
        born = tt[tid == pr].min()
        first_conf = tt[m].min()
        sub_track.update({
            "born_ping": int(ping_of[born]), "confirmed_ping": int(ping_of[first_conf]),
            "last_confirmed_ping": int(pk[m].max()),
            "held_pings": int(mm.size),
            "position_error_m": stats(np.linalg.norm(d, axis=1)),
            "position_error_last_m": round(float(np.linalg.norm(d[-1])), 1),
            "velocity_error_mps": stats(np.linalg.norm(vxy[mm] - s_row_v[mm], axis=1)),
            "range_rate_error_mps": stats(rr_trk - rr_true),
            "hits": int(np.sum(row[m] >= 0)), "coasts": int(np.sum(row[m] < 0))})
    cl_xy = truth.sc_pos[truth.clutter]
    others = classify_other_tracks(ids, pr, conf, tid, xy, pk, row, s_row_xy, mirror_sub, o_xy,
                                   o_hd, cl_xy, gate, contact_snr_db)
    by_class: dict = {}
    for o in others:
        b = by_class.setdefault(o["class"], {"tracks": 0, "max_confirmed_pings": 0,
                                             "longer_than_3_pings": 0})
        b["tracks"] += 1
        b["max_confirmed_pings"] = max(b["max_confirmed_pings"], o["confirmed_pings"])
        b["longer_than_3_pings"] += int(o["confirmed_pings"] > 3)
    est = [xy[conf & (pk == k)] for k in range(n_ping)]
    tp = sub_truth.copy()
    tp[:, ~sub_det] = np.nan
    g = over_time(tp, est, cutoff, 2.0, 2.0)
    n_tent = int(np.unique(tid).size)
    return ({"n_tracks": n_tent, "n_confirmed": int(ids.size),
                   "scan_time_minus_ping_time_max_s": round(scan_err, 3),
                   "submarine": sub_track, "other_confirmed": others,
                   "other_by_class": by_class,
                   "gospa_cutoff_m": cutoff,
                   "gospa_mean_m": round(float(g["gospa"].mean()), 1),
                   "gospa_after_confirmation_mean_m": round(float(
                       g["gospa"][sub_track.get("confirmed_ping", 0):].mean()), 1)},
            {"own": truth.own, "sub": truth.sub, "clutter": cl_xy, "ping_t": ping_t,
             "tid": tid, "conf": conf, "xy": xy, "tt": tt, "row": row,
             "principal": pr, "others": others, "gospa": g["gospa"],
             "labels": sc.labels, "sub_at": sub_at, "own_at": own_at})




def classify_other_tracks(ids, pr, conf, tid, xy, pk, row, s_row_xy, mirror_sub, o_xy, o_hd,
                          cl_xy, gate, contact_snr_db) -> list[dict]:
    """Each confirmed track other than the submarine's principal one: the class it follows
    longest within ``gate`` (submarine, its mirror, clutter, clutter mirror; else
    ``false_alarms``), its confirmed life in pings and its hits."""
    ct = {"snr_db": contact_snr_db}
    others = []
    for i in ids:
        if int(i) == pr:
            continue
        m = conf & (tid == i)
        p = xy[m]
        d_sub = np.linalg.norm(p - s_row_xy[m], axis=1)
        d_mir = np.linalg.norm(p - mirror_sub[m], axis=1)
        d_cl = np.linalg.norm(p[:, None] - cl_xy[None], axis=-1).min(1)
        cl_mir = _mirror(np.repeat(o_xy[m], len(cl_xy), 0), np.repeat(o_hd[m], len(cl_xy)),
                         np.tile(cl_xy, (m.sum(), 1))).reshape(m.sum(), len(cl_xy), 2)
        d_clm = np.linalg.norm(p[:, None] - cl_mir, axis=-1).min(1)
        frac = {k: float(np.mean(v < gate)) for k, v in
                (("submarine", d_sub), ("submarine_mirror", d_mir), ("clutter", d_cl),
                 ("clutter_mirror", d_clm))}
        best = max(frac, key=frac.get)
        kind = best if frac[best] >= 0.5 else "false_alarms"
        others.append({"track_id": int(i), "class": kind,
                       "confirmed_pings": int(m.sum()),
                       "first_confirmed_ping": int(pk[m].min()),
                       "last_confirmed_ping": int(pk[m].max()),
                       "hits_while_confirmed": int(np.sum(row[m] >= 0)),
                       "hits_total": int(np.sum((tid == i) & (row >= 0))),
                       "snr_db_of_hits": [round(float(ct["snr_db"][r]), 1)
                                          for r in row[(tid == i) & (row >= 0)]]})
    return others


def evaluate(rec: Path, prod: Path, tracks: Path, tracker_cfg: str, gate: float,
             cutoff: float) -> dict:
    """Contacts and tracks scores; the arrays the figures need under ``_plot``."""
    truth = read_truth(rec)
    contacts, aux = score_contacts(truth, prod, tracker_cfg)
    trk, plot = score_tracks(truth, tracks, aux["sub_det"], aux["snr_db"], gate, cutoff)
    return {"contacts": contacts, "tracks": trk, "_plot": plot}


def stats(v: np.ndarray) -> dict:
    v = np.asarray(v, float)
    if v.size == 0:
        return {"n": 0}
    return {"n": int(v.size), "mean": round(float(v.mean()), 3),
            "median": round(float(np.median(v)), 3),
            "rms": round(float(np.sqrt(np.mean(v ** 2))), 3),
            "max_abs": round(float(np.abs(v).max()), 3)}


