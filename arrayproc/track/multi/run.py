"""``arrayproc track`` with ``type = "multi"``: the products' rows of one measurement kind
tracked by its composition (:mod:`~arrayproc.track.multi.bearings`,
:mod:`~arrayproc.track.multi.contacts`, :mod:`~arrayproc.track.multi.positions`), written as
one ``tracks`` group."""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import numpy as np

from arrayproc.config import resolve_beside
from arrayproc.errors import ConfigError, FormatError
from arrayproc.geo.nav import Nav
from arrayproc.io.schema import groups_of_kind
from arrayproc.io.text import as_text
from arrayproc.track.manage.tracks import STATUS_CODES, Status, Track, status_names
from arrayproc.track.multi.bearings import bearing_scans, track_cones
from arrayproc.track.multi.config import split_config
from arrayproc.track.multi.contacts import contact_scans, contacts_manager, drop_twin_births
from arrayproc.track.multi.positions import positions_manager
from arrayproc.track.multi.tma import tma_track
from arrayproc.track.state import Context

_log = logging.getLogger(__name__)

__all__ = ["multi_target", "run_multi", "confirmed_status", "effective_config", "write_tracks"]


def _cartesian_rows(tr: Track, nav: Nav | None, ndim: int) -> dict[str, np.ndarray]:
    from arrayproc.track.single import ownship_states

    h = tr.arrays()
    X, P = h["x"], h["P"]
    idx = [0, 1, ndim, ndim + 1]
    out = {"time": h["time"], "x": X[:, 0], "y": X[:, 1], "vx": X[:, ndim],
           "vy": X[:, ndim + 1], "cov": P[:, idx][:, :, idx], "status": h["status"],
           "side_weight": np.full(h["time"].size, np.nan), "row": tr.meta["rows"]}
    if ndim == 3:
        out["z"] = X[:, 2]
        out["vz"] = X[:, 5]
    if nav is not None:
        own, _ = ownship_states(nav, h["time"])
        out["own_x"], out["own_y"] = own[:, 0], own[:, 1]
    else:  # no recording named: the ownship is unknown
        out["own_x"] = out["own_y"] = np.full(h["time"].size, np.nan)
    return out



def _group(prod: dict, kind: str, products_path: str, name: str | None = None) -> dict:
    groups = groups_of_kind(prod, kind)
    if name is not None:
        if name not in groups:
            raise FormatError(f"{products_path}: no {kind} group {name!r}")
        return prod[name]
    if not groups:
        raise FormatError(f"{products_path}: no {kind} group")
    if len(groups) > 1:
        raise ConfigError(f"{products_path}: several {kind} groups ({', '.join(groups)})")
    return prod[groups[0]]


def _columns(g: dict, names: tuple[str, ...], products_path: str) -> dict[str, np.ndarray]:
    for k in names:
        if k not in g:
            raise FormatError(f"{products_path}: column {k!r} is missing")
    out = {k: np.asarray(g[k], float) for k in names}
    n = out[names[0]].shape[0]
    if any(v.shape[0] != n for v in out.values()):
        raise FormatError(f"{products_path}: columns have unequal lengths")
    return out


def multi_target(products_path: str, cfg: dict[str, Any], tma_cfg: dict[str, Any],
                 nav: Nav | None) -> tuple[list[Track], list[dict[str, np.ndarray]]]:
    """Run the multi-target tracker on a products file; returns the tracks and the rows to
    write for each (None-free, tracks with fewer than two rows left out)."""
    from arrayproc.io.products import read_products

    prod = read_products(products_path)
    kind = cfg["measurements"]
    if kind == "bearings":
        return _bearings(prod, products_path, cfg, tma_cfg, nav)
    if kind in ("lines+bearings", "lines"):
        return _lines(prod, products_path, cfg, tma_cfg, nav)
    if kind == "contacts":
        return _contacts(prod, products_path, cfg, nav)
    return _positions(prod, products_path, cfg, nav)


Result = tuple[list[Track], list[dict[str, np.ndarray]]]


def _bearings(prod: dict, products_path: str, cfg: dict[str, Any], tma_cfg: dict[str, Any],
              nav: Nav | None) -> Result:
    """Bearing rows → scans → cone tracks → one TMA per track."""
    out: list[dict[str, np.ndarray]] = []
    g = _group(prod, "bearings", products_path, tma_cfg.get("bearings"))
    b = _columns(g, ("time", "cone_deg", "bearing_port_deg", "bearing_stbd_deg"),
                 products_path)
    if "side" in g:  # relative-bearing beams (lr_cbf): the side each row was resolved to
        b["side"] = np.asarray(g["side"], float)
    score = np.asarray(g.get("snr_db", g.get("level_db", np.zeros_like(b["time"]))), float)
    ok = np.isfinite(b["time"]) & np.isfinite(b["cone_deg"])
    if "cone_gate" in tma_cfg:
        lo, hi = tma_cfg["cone_gate"]
        ok &= (b["cone_deg"] >= lo) & (b["cone_deg"] <= hi)
    idx = np.flatnonzero(ok)
    # a volumetric array's rows (azimuth_deg, port = starboard) merge on their azimuths: two
    # directions with one cone angle about the body x axis are two measurements
    key = np.asarray(g["azimuth_deg"], float) if "azimuth_deg" in g else b["cone_deg"]
    scans = bearing_scans(b["time"][idx], key[idx],
                          np.where(np.isfinite(score[idx]), score[idx], -np.inf),
                          float(cfg["bearing"]["merge_deg"]))
    scans = [(t, np.stack([b["cone_deg"][idx[r]], b["bearing_port_deg"][idx[r]],
                           b["bearing_stbd_deg"][idx[r]]], 1), idx[r])
             for t, _Z, r in scans]
    tracks = track_cones(scans, cfg, nav)
    for tr in tracks:
        rows = tma_track(tr, b, nav, tma_cfg, by_side=cfg["bearing"]["space"] == "bearing")
        if rows is not None:
            out.append(rows)
        else:
            tr.meta["skipped"] = True
    return [tr for tr in tracks if not tr.meta.get("skipped")], out


def effective_config(products_path: str, cfg: dict[str, Any]) -> dict[str, Any]:
    """The multi settings ``cfg`` for a products file: ``lines+bearings`` needs a ``lines``
    group beside cone-angle bearings; otherwise (no lines stage in the chain; relative-bearing
    beams, whose rows are resolved to their side) a warning, and the bearings alone."""
    import warnings

    from arrayproc.io.products import read_products

    if cfg["measurements"] != "lines+bearings":
        return cfg
    prod = read_products(products_path)
    has = bool(groups_of_kind(prod, "lines"))
    sided = any("side" in prod[g] for g in groups_of_kind(prod, "bearings"))
    if has and not sided:
        return cfg
    warnings.warn(f"{products_path}: tracker.measurements = 'lines+bearings': " + (
        "the bearings are resolved to their side (relative-bearing beams)" if sided else
        "the products have no lines group (no lines stage in the chain)")
        + "; tracking the bearings alone", stacklevel=2)
    return dict(cfg, measurements="bearings")


def _lines(prod: dict, products_path: str, cfg: dict[str, Any], tma_cfg: dict[str, Any],
           nav: Nav | None) -> Result:
    """Line contacts (and broadband bearings) → scans → tracks with tonal slots → one TMA per
    track, each point with its measurement (:func:`_measurement_columns`)."""
    from arrayproc.track.multi.lines import (
        line_scans,
        line_table,
        row_sigma_deg,
        snapshot_times,
        track_lines,
    )

    m = line_table(prod, products_path, cfg, tma_cfg)
    scans = line_scans(m, cfg, snapshot_times(prod))
    tracks = track_lines(scans, cfg, nav, _sound_speed(products_path))
    sig = row_sigma_deg(m, cfg) / np.maximum(np.sin(np.deg2rad(m["cone_deg"])),
                                             float(cfg["bearing"]["min_sigma_sin"]))
    out, kept = [], []
    for tr in tracks:
        r = tr.meta["rows"][tr.meta["rows"] >= 0]
        # the TMA's bearing σ: the filter's, or the RMS cone σ of the track's rows if larger
        s_rows = float(np.sqrt(np.mean(sig[r] ** 2))) if r.size else 0.0
        cfg_tr = dict(tma_cfg, sigma_bearing_deg=max(float(tma_cfg["sigma_bearing_deg"]), s_rows))
        rows = tma_track(tr, m, nav, cfg_tr, by_side=True)
        if rows is None:
            continue
        out.append(_measurement_columns(tr, m, rows))
        kept.append(tr)
    return kept, out


def _measurement_columns(tr: Track, m: dict[str, np.ndarray], rows: dict[str, np.ndarray]
                         ) -> dict[str, np.ndarray]:
    """The TMA rows of a tonal track with its tonals and, per point, the measurement that
    updated it: ``row`` (index in its products group), ``row_kind`` (0 bearings, 1 lines, −1
    coasted), ``meas_cone_deg``, ``meas_port_deg``, ``meas_stbd_deg``, ``meas_freq_hz`` (NaN
    broadband or coasted), ``meas_tonal`` (its slot), ``f_hz`` / ``sigma_f_hz`` (n, K) the
    track's tonals (NaN: empty slot)."""
    n_all = tr.meta["rows"].size
    keep = np.zeros(n_all, bool)
    keep[n_all - rows["time"].size:] = True  # tma_track drops the points before its first row
    r = tr.meta["rows"][keep]
    on = r >= 0
    rs = np.where(on, r, 0)

    def pick(col: str) -> np.ndarray:
        return np.where(on, m[col][rs], np.nan)

    out = dict(rows)
    out["row"] = np.where(on, m["row"][rs], -1).astype(np.int64)
    out["row_kind"] = np.where(on, m["kind"][rs], -1).astype(np.int8)
    out["meas_cone_deg"] = pick("cone_deg")
    out["meas_port_deg"] = pick("bearing_port_deg")
    out["meas_stbd_deg"] = pick("bearing_stbd_deg")
    out["meas_freq_hz"] = pick("freq_hz")
    out["meas_tonal"] = np.where(on, tr.meta["meas_tonal"][keep], -1).astype(np.int64)
    out["f_hz"] = tr.meta["f_hz"][keep]
    out["sigma_f_hz"] = tr.meta["sigma_f_hz"][keep]
    return out


def _contacts(prod: dict, products_path: str, cfg: dict[str, Any], nav: Nav | None) -> Result:
    """Contacts → scans per ping → Cartesian tracks."""
    g = _group(prod, "contacts", products_path)
    c = _columns(g, ("time", "range_m", "bearing_port_deg", "bearing_stbd_deg",
                     "range_rate_mps"), products_path)
    if "ping" in g:
        c["ping"] = np.asarray(g["ping"], np.int64)
    keep = np.ones(c["time"].size, bool)
    for key, col in (("moving_only", "moving"), ("min_snr_db", "snr_db")):
        if cfg["contacts"][key] and col not in g:
            raise FormatError(f"{products_path}: tracker.contacts.{key} needs the "
                              f"contacts' {col!r} column")
    if cfg["contacts"]["moving_only"]:
        keep &= np.asarray(g["moving"], bool)
    if cfg["contacts"]["min_snr_db"] > 0:
        keep &= np.asarray(g["snr_db"], float) >= cfg["contacts"]["min_snr_db"]
    scans = contact_scans(c, nav, bool(cfg["contacts"]["mirror"]),
                          _sound_speed(products_path), keep)
    mgr = contacts_manager(cfg)
    for t, Z, r, own in scans:
        n0 = len(mgr.tracks)
        mgr.step(t, Z, Context(own))
        drop_twin_births(mgr.tracks, n0, t, r)
    _attach_rows(mgr.tracks, [(t, r) for t, _Z, r, _o in scans])
    return mgr.tracks, [_cartesian_rows(tr, nav, 2) for tr in mgr.tracks]


def _positions(prod: dict, products_path: str, cfg: dict[str, Any], nav: Nav | None
               ) -> Result:
    """Position fixes → scans per time → 3-D tracks."""
    g = _group(prod, "positions", products_path)
    p = _columns(g, ("time", "x", "y", "z", "cov"), products_path)
    mgr = positions_manager(cfg)
    t = p["time"]
    order = np.argsort(t, kind="stable")
    scans2 = []
    for seg in np.split(order, np.flatnonzero(np.diff(t[order]) != 0) + 1):
        if seg.size:
            Z = np.stack([p["x"][seg], p["y"][seg], p["z"][seg]], 1)
            mgr.step(float(t[seg[0]]), Z, Context(np.zeros(4), meas_cov=p["cov"][seg]))
            scans2.append((float(t[seg[0]]), seg))
    _attach_rows(mgr.tracks, scans2)
    return mgr.tracks, [_cartesian_rows(tr, nav, 3) for tr in mgr.tracks]


def _sound_speed(products_path: str) -> float:
    """Sound speed (m/s) of the recording a products file was made from (its root attribute
    ``source``); the recording format's default when the recording cannot be opened."""
    import os

    from arrayproc.io.products import read_products
    from arrayproc.io.recording import DEFAULT_SOUND_SPEED, Recording

    src = as_text(read_products(products_path)["/"].get("source", ""))
    rec = resolve_beside(src, products_path) if src else ""
    if not rec or not os.path.exists(rec):
        return DEFAULT_SOUND_SPEED
    with Recording(rec, require_geometry=False) as r:
        return float(r.sound_speed)


def _attach_rows(tracks: list[Track], scans: list[tuple[float, np.ndarray]]) -> None:
    rows_at = dict(scans)
    for tr in tracks:
        h = tr.arrays()
        tr.meta["rows"] = np.array([rows_at[float(tk)][j] if j >= 0 else -1
                                    for tk, j in zip(h["time"], h["meas"], strict=True)],
                                   np.int64)


def run_multi(products_path: str, config_path: str, out_path: str,
              progress: bool = False,
              checked: tuple[dict[str, Any], dict[str, Any]] | None = None) -> None:
    """``arrayproc track PRODUCTS.h5 -c TRACKER.toml -o TRACKS.h5`` with ``type = "multi"``:
    writes one ``tracks`` group, one row per track per scan of its life (status tentative,
    confirmed or deleted); ``checked`` the (multi, TMA) settings of
    :func:`~arrayproc.track.multi.config.check_multi_config` when the caller has read the file
    already."""
    import os

    from arrayproc.io.products import read_products
    from arrayproc.track.single import _read_nav

    if checked is None:
        checked = split_config(config_path)
    cfg, tma_cfg = checked
    if not os.path.exists(products_path):
        raise FormatError(f"{products_path}: no such file")
    root = read_products(products_path)["/"]
    src = tma_cfg.get("nav") or as_text(root.get("source", ""))
    nav = None
    rec = ""
    if src:
        rec = resolve_beside(src, config_path if tma_cfg.get("nav") else products_path)
        nav = _read_nav(rec)
    elif cfg["measurements"] != "positions":
        raise FormatError(f"{products_path}: no root attribute 'source' naming the recording; "
                          "set tracker.nav")
    cfg = effective_config(products_path, cfg)
    tracks, rows = multi_target(products_path, cfg, tma_cfg, nav)
    if progress:
        n_conf = sum(tr.confirmed_at is not None for tr in tracks)
        _log.info(f"{len(tracks)} tracks, {n_conf} confirmed")
    write_tracks(out_path, tracks, rows, config_path, str(products_path), cfg, tma_cfg,
                 root_attrs={"recording": str(rec)})


def write_tracks(out_path: str, tracks: list[Track], rows: list[dict[str, np.ndarray]],
                 config_path: str, source: str, cfg: dict[str, Any], tma_cfg: dict[str, Any],
                 root_attrs: dict[str, Any] | None = None, **group_attrs: Any) -> None:
    """Write the multi-target tracker's ``tracks`` group: one row per track per scan of its
    life, ``rows`` the columns of each track (``track_id`` added, ``status`` coded);
    ``root_attrs`` and ``group_attrs`` beside the usual ones."""
    from arrayproc.io.products import ProductsWriter

    cfg_text = Path(config_path).read_text(encoding="utf-8", errors="replace")
    with ProductsWriter(out_path, source=source, chain=cfg_text,
                        attrs=dict(root_attrs or {})) as w:
        g = w.group("tracks", "tracks", stage="track", mode="multi",
                    measurements=cfg["measurements"], association=cfg["association"],
                    filter=tma_cfg["filter"], lr=bool(tma_cfg["lr"]), **group_attrs)
        parts = []
        for tr, r in zip(tracks, rows, strict=True):
            n = r["time"].size
            if n == 0:
                continue
            cols = dict(r)
            cols["track_id"] = np.full(n, tr.id, np.int64)
            cols["status"] = np.array([STATUS_CODES[str(s)] for s in cols["status"]],
                                      np.int8)
            parts.append(cols)
        if parts:  # one append: thousands of one-row tentative tracks are common (contacts)
            g.append(**{k: np.concatenate([c[k] for c in parts]) for k in parts[0]})
        if not any(r["time"].size for r in rows):
            g.attrs["empty"] = True


def confirmed_status(status: np.ndarray) -> np.ndarray:
    """Boolean mask of rows whose ``status`` column reads confirmed."""
    return status_names(status) == Status.CONFIRMED.value
