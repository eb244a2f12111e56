"""Line contacts and broadband bearings of a towed line array tracked together
(``measurements = "lines+bearings"`` or ``"lines"``): scans of both kinds, one track manager
with mirrored bearing hypotheses and tonal slots (:mod:`arrayproc.track.multi.tonals`).

Measurements of a scan (one snapshot time), Z (m, 5) = [cone, port bearing, starboard
bearing, frequency, cone σ at broadside] (deg, Hz, deg):

- the broadband rows of the ``bearings`` group (the rows whose band ``freq_hi − freq_lo`` is
  the group's widest; the LOFAR-line rows of a ``bearings`` stage with ``lines = true`` repeat
  the line contacts without their frequency and are left out), merged within ``merge_deg`` as
  in bearings mode, frequency NaN, σ ``tracker.bearing.sigma_cone_deg``;
- every row of the ``lines`` group (``snr_db`` at least ``tracker.lines.min_snr_db``), with its
  ``freq_hz`` and the σ of :func:`~arrayproc.track.multi.tonals.line_sigma_deg`
  (``tracker.lines.sigma_line_deg_hz``, ``min_sigma_line_deg``).

The combined measurement table (broadband rows first, then lines) keeps each row's group
(``kind`` 0 bearings, 1 lines) and its index in that group, written with every track point.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from arrayproc.errors import ConfigError, FormatError
from arrayproc.geo.nav import Nav
from arrayproc.io.schema import groups_of_kind
from arrayproc.track.manage.tracks import Status, Track
from arrayproc.track.multi.bearings import bearing_scans
from arrayproc.track.multi.stitch import stitch_by_tonals
from arrayproc.track.multi.tonals import (
    TonalBank,
    TonalDistinct,
    TonalGNN,
    birth_tonals,
    line_sigma_deg,
    tonal_bearing_bank,
    tonal_slots,
)
from arrayproc.track.state import Context

__all__ = ["line_table", "line_scans", "row_sigma_deg", "snapshot_times", "track_lines",
           "KIND_BEARINGS", "KIND_LINES"]

#: ``row_kind`` of a track point updated by a broadband bearing / by a line contact
KIND_BEARINGS, KIND_LINES = 0, 1
_COLS = ("time", "cone_deg", "bearing_port_deg", "bearing_stbd_deg")


def _one_group(prod: dict, kind: str, products_path: str, name: str | None) -> dict | None:
    groups = groups_of_kind(prod, kind)
    if name is not None:
        if name not in groups:
            raise FormatError(f"{products_path}: no {kind} group {name!r}")
        return prod[name]
    if len(groups) > 1:
        raise ConfigError(f"{products_path}: several {kind} groups ({', '.join(groups)})")
    return prod[groups[0]] if groups else None


def _cols(g: dict, names: tuple[str, ...], products_path: str, kind: str
          ) -> dict[str, np.ndarray]:
    for k in names:
        if k not in g:
            raise FormatError(f"{products_path}: {kind} column {k!r} is missing")
    out = {k: np.asarray(g[k], float).reshape(-1) for k in names}
    if len({v.size for v in out.values()}) > 1:
        raise FormatError(f"{products_path}: {kind} columns have unequal lengths")
    return out


def _broadband(g: dict) -> np.ndarray:
    """Rows of a ``bearings`` group that are broadband peaks (widest band)."""
    n = np.asarray(g["time"]).size
    if "freq_lo" not in g or "freq_hi" not in g or n == 0:
        return np.ones(n, bool)
    w = np.asarray(g["freq_hi"], float) - np.asarray(g["freq_lo"], float)
    return w >= np.nanmax(w) * (1 - 1e-9)


def snapshot_times(prod: dict) -> np.ndarray:
    """Times (s) of the integrated snapshots of a products file (its ``btr`` or ``lofar``
    groups), empty when it has none."""
    for kind in ("btr", "lofar"):
        groups = groups_of_kind(prod, kind)
        if groups:
            return np.unique(np.asarray(prod[groups[0]]["time"], float))
    return np.zeros(0)


def line_table(prod: dict, products_path: str, cfg: dict[str, Any], tma_cfg: dict[str, Any]
               ) -> dict[str, np.ndarray]:
    """The combined measurement table of a products file (module doc): columns ``time``,
    ``cone_deg``, ``bearing_port_deg``, ``bearing_stbd_deg``, ``freq_hz`` (NaN broadband),
    ``snr_db``, ``kind`` and ``row`` (index in its group)."""
    parts = []
    if cfg["measurements"] == "lines+bearings":
        g = _one_group(prod, "bearings", products_path, tma_cfg.get("bearings"))
        if g is None:
            raise FormatError(f"{products_path}: no bearings group (measurements = "
                              "'lines+bearings'; 'lines' uses the line contacts only)")
        if "side" in g:
            raise ConfigError(f"{products_path}: lines+bearings needs cone-angle bearings, "
                              "not relative-bearing beams")
        b = _cols(g, _COLS, products_path, "bearings")
        sel = np.flatnonzero(_broadband(g) & np.isfinite(b["time"]) & np.isfinite(b["cone_deg"]))
        snr = np.asarray(g.get("snr_db", g.get("level_db", np.zeros(b["time"].size))), float)
        parts.append({**{k: b[k][sel] for k in _COLS}, "freq_hz": np.full(sel.size, np.nan),
                      "snr_db": snr[sel], "kind": np.full(sel.size, KIND_BEARINGS),
                      "row": sel})
    g = _one_group(prod, "lines", products_path, None)
    if g is None:
        raise FormatError(f"{products_path}: no lines group (measurements = "
                          f"{cfg['measurements']!r}; the chain needs a 'lines' stage)")
    c = _cols(g, _COLS + ("freq_hz", "snr_db"), products_path, "lines")
    ok = np.isfinite(c["time"]) & np.isfinite(c["cone_deg"]) & np.isfinite(c["freq_hz"])
    if cfg["lines"]["min_snr_db"] > 0:
        ok &= c["snr_db"] >= cfg["lines"]["min_snr_db"]
    sel = np.flatnonzero(ok)
    parts.append({**{k: c[k][sel] for k in _COLS + ("freq_hz", "snr_db")},
                  "kind": np.full(sel.size, KIND_LINES), "row": sel})
    out = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    if "cone_gate" in tma_cfg:
        lo, hi = tma_cfg["cone_gate"]
        keep = (out["cone_deg"] >= lo) & (out["cone_deg"] <= hi)
        out = {k: v[keep] for k, v in out.items()}
    out["kind"] = out["kind"].astype(np.int64)
    out["row"] = out["row"].astype(np.int64)
    return out


def row_sigma_deg(m: dict[str, np.ndarray], cfg: dict[str, Any]) -> np.ndarray:
    """Cone σ at broadside (deg) of every row of the measurement table: a line's from its
    frequency and SNR (:func:`~arrayproc.track.multi.tonals.line_sigma_deg`), a broadband
    row's ``tracker.bearing.sigma_cone_deg``."""
    ll = cfg["lines"]
    return np.where(m["kind"] == KIND_LINES,
                    line_sigma_deg(np.nan_to_num(m["freq_hz"], nan=1.0), m["snr_db"],
                                   float(ll["sigma_line_deg_hz"]),
                                   float(ll["min_sigma_line_deg"])),
                    float(cfg["bearing"]["sigma_cone_deg"]))


def line_scans(m: dict[str, np.ndarray], cfg: dict[str, Any],
               times: np.ndarray | None = None) -> list[tuple[float, np.ndarray, np.ndarray]]:
    """Scans (t, Z (k, 5), rows of ``m``) in time order: the broadband rows of each time merged
    within ``tracker.bearing.merge_deg``
    (:func:`~arrayproc.track.multi.bearings.bearing_scans`), then every line contact (module
    doc); ``times`` (s) are scans too, empty when they hold no row (the snapshots of the
    products: a miss for every track)."""
    merge_deg = float(cfg["bearing"]["merge_deg"])
    sig = row_sigma_deg(m, cfg)
    bb = np.flatnonzero(m["kind"] == KIND_BEARINGS)
    ln = np.flatnonzero(m["kind"] == KIND_LINES)
    score = np.where(np.isfinite(m["snr_db"]), m["snr_db"], -np.inf)
    by_t: dict[float, list[np.ndarray]] = {}
    for t, _Z, r in bearing_scans(m["time"][bb], m["cone_deg"][bb], score[bb], merge_deg):
        by_t.setdefault(t, []).append(bb[r])
    order = ln[np.lexsort((m["freq_hz"][ln], m["time"][ln]))]
    if order.size:
        cuts = np.flatnonzero(np.diff(m["time"][order]) != 0) + 1
        for seg in np.split(order, cuts):
            by_t.setdefault(float(m["time"][seg[0]]), []).append(seg)
    for t in np.asarray([] if times is None else times, float):
        by_t.setdefault(float(t), [])
    out = []
    for t in sorted(by_t):
        rows = np.concatenate(by_t[t] or [np.zeros(0, np.int64)]).astype(np.int64)
        Z = np.stack([m["cone_deg"][rows], m["bearing_port_deg"][rows],
                      m["bearing_stbd_deg"][rows], m["freq_hz"][rows], sig[rows]], 1)
        out.append((t, Z, rows))
    return out


def _tonal_filter(cfg: dict[str, Any], nav: Nav, sound_speed: float) -> TonalBank:
    from arrayproc.track.single import ownship_states

    b, ll = cfg["bearing"], cfg["lines"]

    def own_velocity(t: np.ndarray) -> np.ndarray:
        own, _ = ownship_states(nav, np.asarray(t, float))
        return own[:, 2:4]

    bank = tonal_bearing_bank(float(b["q_bearing"]), float(b["min_sigma_sin"]))
    return TonalBank(bank, int(ll["max_tonals"]), float(ll["sigma_hz"]), float(ll["q_freq"]),
                     float(ll["max_age_s"]), sound_speed, own_velocity)


def track_lines(scans: list[tuple[float, np.ndarray, np.ndarray]], cfg: dict[str, Any],
                nav: Nav, sound_speed: float = 1500.0) -> list[Track]:
    """Run the track manager with tonal slots over line / bearing scans (Z (m, 5)).

    ``meta`` of every track: ``rows`` (row of the measurement table per history point, −1
    coasted), ``cone``, ``sigma_cone``, ``stbd_weight`` (as bearings mode), ``f_hz`` and
    ``sigma_f_hz`` (n, K) its tonals' received frequencies (NaN: empty slot) and
    ``meas_tonal`` (n,) the slot nearest the point's measured frequency (−1: none). Segments
    of one source are joined by their tonals
    (:func:`~arrayproc.track.multi.stitch.stitch_by_tonals`)."""
    from arrayproc.track.manage.delete import DeletionRule
    from arrayproc.track.manage.manager import TrackManager
    from arrayproc.track.manage.mirrored import mirrored_cone, mirrored_initial
    from arrayproc.track.single import ownship_states

    if nav is None:
        raise ConfigError("tracker.measurements = 'lines…' needs the array's navigation")
    if cfg["association"] != "gnn":
        raise ConfigError("tracker.measurements = 'lines…' associates by gnn "
                          "(tracker.association = 'gnn')")
    b, ll = cfg["bearing"], cfg["lines"]
    sr, smin = float(b["sigma_rate_deg_s"]), float(b["min_sigma_sin"])
    filt = _tonal_filter(cfg, nav, sound_speed)
    K = filt.K
    merge = float(b["merge_deg"])

    assoc = TonalGNN(cfg["gate_prob"], float(ll["adopt_d2"]), merge)

    def init(Z: np.ndarray, t: float, ctx: Any, j: int) -> tuple[np.ndarray, ...] | None:
        if not assoc.may_start(Z, j, t):
            return None
        xb, Pb, lw = mirrored_initial(Z[:, :3], j, float(Z[j, 4]), smin, sr)
        f0 = birth_tonals(Z, j, K, float(ll["adopt_d2"]))
        x, P = filt.initial(xb, Pb, f0, float(ll["sigma_rate_hz_s"]))
        return x, P, lw

    ts = np.array([t for t, _Z, _r in scans])
    if ts.size:
        _own, hd = ownship_states(nav, ts)
        rate = np.abs(np.gradient(np.unwrap(hd), ts)) if ts.size > 1 else np.zeros(1)
        qmul = 1.0 + (np.degrees(rate) / float(b["turn_ref_deg_s"])) ** 2
    hw = cfg.get("hit_window")
    window = {} if hw is None else {"window": int(hw[1]), "min_hits": int(hw[0])}
    distinct = TonalDistinct(filt, float(ll["same_source_deg"]), int(ll["same_source_scans"]))
    # duplicates compared on the two mirror bearings, not their rates: the rates of two
    # tracks of one source born at different times differ most in a turn, where the bearing
    # of the mirror sweeps at twice the turn rate, and say nothing of which source they hold
    delete = DeletionRule(max_misses=cfg["max_misses"], **window, pos=(0, 1),
                          merge_d2=float(b["merge_d2"]), distinct=distinct)
    mgr = TrackManager(filt, init, assoc,
                       confirm=cfg["confirm"], delete=delete)
    for k, (t, Z, _rows) in enumerate(scans):
        assoc.confirmed = np.array([tr.status is Status.CONFIRMED for tr in mgr.live], bool)
        mgr.step(t, Z, Context(np.zeros(4), t=float(t), q_scale=float(qmul[k])))
        distinct.absorb(mgr.tracks)
    at = {t: (Z, r) for t, Z, r in scans}
    tracks = stitch_by_tonals(mgr.tracks, K, float(ll["reid_s"]), float(ll["reid_hz"]),
                              float(ll["reid_deg"]))
    for tr in tracks:
        h = tr.arrays()
        rows = np.full(h["meas"].size, -1, np.int64)
        fz = np.full(h["meas"].size, np.nan)
        for k, (tk, j) in enumerate(zip(h["time"], h["meas"], strict=True)):
            if j >= 0:
                Z, r = at[float(tk)]
                rows[k], fz[k] = r[j], Z[j, 3]
        f, _ = tonal_slots(h["x"], K)
        sf = np.sqrt(np.stack([h["P"][:, 4 + 2 * k, 4 + 2 * k] for k in range(K)], 1))
        sf[~np.isfinite(f)] = np.nan
        dist = np.abs(fz[:, None] - f)
        has = np.isfinite(dist).any(1)
        tr.meta["meas_tonal"] = np.where(has, np.argmin(np.where(np.isfinite(dist), dist,
                                                                 np.inf), 1), -1)
        tr.meta["rows"], tr.meta["f_hz"], tr.meta["sigma_f_hz"] = rows, f, sf
        _o, hh = ownship_states(nav, h["time"])
        c, sc, ws = mirrored_cone(filt.bank, np.ascontiguousarray(h["x"][:, :4]),
                                  np.ascontiguousarray(h["P"][:, :4, :4]), h["logw"],
                                  np.degrees(hh))
        tr.meta["cone"], tr.meta["sigma_cone"], tr.meta["stbd_weight"] = c, sc, ws
    return tracks

