"""``arrayproc tma TRACKS.h5``: one batch TMA solution per confirmed track of a tracks file.

A tracks file written by the multi-target tracker (:mod:`arrayproc.track.multi`) holds, for
every point of a track, the index ``row`` of the measurement row it was updated with in the
products group it tracked (−1 when it coasted), and names that products file in its root
attribute ``source`` and the recording in ``recording``. A track's own measurements are the
rows it used; each confirmed track's rows are solved as one batch over their time span
(:func:`.run.solve_window`, the same solvers as a products file), and the solutions are
written as one ``tma`` group with a ``track_id`` column.

Methods (``[tma] method``): ``bearings`` (a line array's cone angles, no side chosen:
:func:`.bo_tma.solve_cone`; both mirror solutions written while the data do not resolve
them, column ``preferred``), ``bearings_frequency`` (the track's line frequencies as well,
rest frequency ``f0`` a fifth parameter: :mod:`.bf_tma`), ``delays`` (the products' delays
rows at the track's times), ``compact`` (azimuth tracks of a volumetric/planar array:
:mod:`.compact`), or ``auto``: ``bearings_frequency`` for a track with line frequencies on at
least ``min_rows`` of its rows, else ``bearings``.

A track's frequencies: a tracks file of the lines+bearings tracker holds each point's
measurement (``meas_cone_deg``, ``meas_port_deg``, ``meas_stbd_deg``, ``meas_freq_hz``, and
``meas_tonal`` the tonal slot it updated); its rows are read from there, and the frequencies
are those of the tonal with the most rows (one rest frequency ``f0``; the other rows, broadband
bearings or other tonals, enter with their angle alone). A tonal is a run of the track's line
frequencies with no gap wider than :data:`TONAL_GAP_HZ` (:func:`tonal_labels`), not a tonal
slot of the tracker: a slot may hold two tonals one after the other. A tracks file of bearings alone
(``row`` indexes the products' ``bearings`` group, or the ``lines`` group named by
``tma.group``, whose ``freq_hz`` then gives the frequencies) is read through its products file.

Written here: the selection of a track's rows is the only new part; the solvers are shared.
"""

from __future__ import annotations

import logging
import os
import warnings
from typing import Any

import numpy as np

from arrayproc.config import resolve_beside
from arrayproc.errors import ConfigError, FormatError
from arrayproc.io.products import delays_columns, read_products
from arrayproc.io.recording import Recording
from arrayproc.io.schema import groups_of_kind
from arrayproc.io.text import as_text
from arrayproc.track.manage.tracks import STATUS_CODES, Status

from .result import TmaSolution
from .run import (
    bearing_columns,
    load_tma_config,
    select_rows,
    solve_window,
    warn_if_far,
    with_unresolved_mirrors,
    write_tma,
)

_log = logging.getLogger(__name__)

__all__ = ["is_tracks_file", "TrackRows", "read_track_rows", "tonal_labels", "track_method",
           "run_tracks_tma", "TONAL_GAP_HZ"]

_CONFIRMED = STATUS_CODES[Status.CONFIRMED.value]
#: line rows of one track whose sorted frequencies are further apart than this are two tonals,
#: Hz (a few FFT bins of the shipped chain's 1 Hz; a tonal's own rows are far denser)
TONAL_GAP_HZ = 2.0


def is_tracks_file(path: str) -> bool:
    """Whether a products file holds a ``tracks`` group (the input of per-track TMA)."""
    try:
        return bool(groups_of_kind(read_products(path), "tracks"))
    except Exception:  # not a products file: the products path reports it
        return False


class TrackRows:
    """The tracks file's confirmed tracks and their measurement rows.

    Attributes
    ----------
    tracks : dict
        ``{track_id: measurements}``, each as :func:`.run.select_rows` (``time``, ``cone``,
        ``heading``, ``port``, ``stbd``, ``azimuth``, ``freq``), one row per time, in time
        order; also ``rows`` (the indices in the products group).
    products, recording, group : str
        The products file, the recording and the products group the rows index.
    prod : ProductsFile
        The products file as read (for the delays method).
    """

    def __init__(self, tracks: dict[int, dict[str, Any]], products: str, recording: str,
                 group: str, prod: Any) -> None:
        self.tracks = tracks
        self.products = products
        self.recording = recording
        self.group = group
        self.prod = prod


def _tracks_group(path: str) -> dict:
    prod = read_products(path)
    names = groups_of_kind(prod, "tracks")
    if not names:
        raise FormatError(f"{path}: no tracks group")
    if len(names) > 1:
        raise FormatError(f"{path}: several tracks groups ({', '.join(names)})")
    g = prod[names[0]]
    for k in ("track_id", "status", "row", "time"):
        if k not in g:
            raise FormatError(f"{path}: tracks column {k!r} is missing (per-track TMA needs "
                              "the multi-target tracker's tracks, type = 'multi')")
    meas = as_text(g["attrs"].get("measurements", "bearings"))
    if meas not in ("bearings", "lines+bearings", "lines"):
        raise FormatError(f"{path}: per-track TMA solves bearing tracks; these tracks are of "
                          f"{meas!r}")
    return {"group": g, "root": prod["/"]}


def read_track_rows(tracks_path: str, cfg: dict[str, Any]) -> TrackRows:
    """Every confirmed track's own measurement rows (module doc).

    Parameters
    ----------
    tracks_path : str
        Tracks file written by ``arrayproc track`` with ``type = "multi"``.
    cfg : dict
        Checked TMA configuration (``group``, ``recording``, ``cone_gate``).

    Returns
    -------
    TrackRows
    """
    tg = _tracks_group(tracks_path)
    g, root = tg["group"], tg["root"]
    src = as_text(root.get("source", ""))
    if not src:
        raise FormatError(f"{tracks_path}: no root attribute 'source' naming the products file")
    products = resolve_beside(src, tracks_path)
    if not os.path.exists(products):
        raise FormatError(f"{tracks_path}: the products file it was made from, {products}, "
                          "does not exist")
    rec = cfg["recording"] or as_text(root.get("recording", ""))
    ids = np.asarray(g["track_id"], np.int64).reshape(-1)
    status = np.asarray(g["status"]).reshape(-1)
    rows = np.asarray(g["row"], np.int64).reshape(-1)
    confirmed = np.unique(ids[status == _CONFIRMED])
    if confirmed.size == 0:
        raise FormatError(f"{tracks_path}: no confirmed track")
    if "meas_cone_deg" in g:  # lines+bearings tracks: each point holds its measurement
        out = {int(tid): _own_measurements(g, ids == tid, cfg) for tid in confirmed}
        return TrackRows(out, products, rec, as_text(g["attrs"].get("measurements", "")),
                         None)
    if as_text(g["attrs"].get("measurements", "bearings")) != "bearings":
        raise FormatError(f"{tracks_path}: lines tracks without their per-point measurements "
                          "(meas_cone_deg …): their rows index two products groups")
    prod = read_products(products)
    name = cfg["group"] or as_text(g["attrs"].get("group", ""))
    if name:
        if name not in prod or name == "/":
            raise FormatError(f"{products}: no group {name!r}")
    else:
        names = groups_of_kind(prod, "bearings")
        if len(names) != 1:
            raise FormatError(f"{products}: {len(names)} bearings groups; name the one tracked "
                              "with tma.group")
        name = names[0]
    cols = bearing_columns(prod[name], products)
    n_rows = cols["time"].size
    cone_deg = (np.asarray(prod[name]["cone_deg"], float).reshape(-1)
                if "cone_deg" in prod[name] else None)
    out = {}
    for tid in confirmed:
        sel = (ids == tid) & (rows >= 0)
        r = np.unique(rows[sel])
        if np.any(r >= n_rows):
            raise FormatError(f"{tracks_path}: track {tid} uses row {int(r.max())} but the "
                              f"products group {name!r} has {n_rows} rows")
        if cfg["cone_gate"] is not None and cone_deg is not None:
            r = r[(cone_deg[r] >= cfg["cone_gate"][0]) & (cone_deg[r] <= cfg["cone_gate"][1])]
        r = r[np.argsort(cols["time"][r], kind="stable")]
        _, uniq = np.unique(cols["time"][r], return_index=True)   # one row per time
        r = r[uniq]
        m = select_rows(cols, r)
        m["rows"] = r
        out[int(tid)] = m
    return TrackRows(out, products, rec, name, prod)


def _own_measurements(g: dict, mask: np.ndarray, cfg: dict[str, Any]) -> dict[str, Any]:
    """One track's measurements from a tracks group that holds them per point
    (``meas_cone_deg``, ``meas_port_deg``, ``meas_stbd_deg``, ``meas_freq_hz``,
    ``meas_tonal``): the points that used a row, one per time; ``freq`` the frequencies of
    the tonal (:func:`tonal_labels`) with the most rows (NaN on the other rows: broadband
    bearings or other tonals), None when no row has one."""
    used = mask & (np.asarray(g["row"]).reshape(-1) >= 0)
    if "row_kind" in g:
        used &= np.asarray(g["row_kind"]).reshape(-1) >= 0
    idx = np.flatnonzero(used)
    t = np.asarray(g["time"], float).reshape(-1)
    idx = idx[np.argsort(t[idx], kind="stable")]
    _, first = np.unique(t[idx], return_index=True)
    idx = idx[first]
    col = {k: np.asarray(g[k], float).reshape(-1)[idx] if k in g else None
           for k in ("meas_cone_deg", "meas_port_deg", "meas_stbd_deg", "meas_freq_hz")}
    if cfg["cone_gate"] is not None:
        keep = (col["meas_cone_deg"] >= cfg["cone_gate"][0]) & \
            (col["meas_cone_deg"] <= cfg["cone_gate"][1])
        idx = idx[keep]
        col = {k: None if v is None else v[keep] for k, v in col.items()}
    freq = None
    f = col["meas_freq_hz"]
    if f is not None and np.any(np.isfinite(f)):
        slot = (np.asarray(g["meas_tonal"]).reshape(-1)[idx] if "meas_tonal" in g
                else np.zeros(idx.size, np.int64))
        on = np.isfinite(f) & (slot >= 0)
        if on.any():
            label = tonal_labels(f, on)
            best = np.bincount(label[on]).argmax()
            freq = np.where(on & (label == best), f, np.nan)
    cols = {"time": t[idx], "port": col["meas_port_deg"], "stbd": col["meas_stbd_deg"],
            "azimuth": None, "freq": freq}
    m = select_rows(cols, np.arange(idx.size))
    m["rows"] = np.asarray(g["row"]).reshape(-1)[idx]
    return m


def tonal_labels(freq: np.ndarray, on: np.ndarray, gap_hz: float = TONAL_GAP_HZ
                 ) -> np.ndarray:
    """One label per tonal of a track's line rows: the rows ``on`` sorted by frequency, split
    where neighbouring frequencies are more than ``gap_hz`` apart (−1 off the rows ``on``).

    A tracker's tonal slot is not one tonal: a slot freed by a faded tonal takes the next, and
    one tonal may move between slots, so the slot label mixes tonals that one rest frequency
    ``f0`` cannot fit. One tonal's received frequencies form one dense run however far its
    Doppler sweeps (the rows are seconds apart, its rate at most a few tens of mHz/s);
    two tonals are split by a gap with no rows in it."""
    label = np.full(freq.size, -1, np.int64)
    i = np.flatnonzero(on)
    if i.size == 0:
        return label
    order = i[np.argsort(freq[i], kind="stable")]
    label[order] = np.r_[0, np.cumsum(np.diff(freq[order]) > gap_hz)]
    return label


def track_method(meas: dict[str, Any], cfg: dict[str, Any]) -> str:
    """The method for one track: the configured one, or for ``auto`` ``bearings_frequency``
    when at least ``min_rows`` of its rows have a frequency, else ``bearings``."""
    if cfg["method"] != "auto":
        return cfg["method"]
    f = meas.get("freq")
    return "bearings_frequency" if f is not None and \
        int(np.isfinite(f).sum()) >= cfg["min_rows"] else "bearings"


def _delays_rows(tr: TrackRows, meas: dict[str, Any], path: str) -> dict[str, Any]:
    """The products' delays rows at the track's times (within 1 µs)."""
    if tr.prod is None:
        tr.prod = read_products(tr.products)
    names = groups_of_kind(tr.prod, "delays")
    if len(names) != 1:
        raise ConfigError(f"{path}: tma.method = 'delays' needs one delays group in "
                          f"{tr.products} ({len(names)} found)")
    d = delays_columns(tr.prod[names[0]], tr.products)
    t = meas["time"]
    j = np.clip(np.searchsorted(d["time"], t), 0, max(d["time"].size - 1, 0))
    j = np.unique(np.concatenate([j, np.clip(j - 1, 0, None)]))
    j = j[np.min(np.abs(d["time"][j][:, None] - t[None, :]), axis=1) < 1e-6] \
        if d["time"].size else j[:0]
    sig = None if d["sigma"] is None else d["sigma"][j]
    return {"time": d["time"][j], "tau": d["tau"][j], "sigma": sig,
            "reference": d["reference"]}


def _solve_track(tid: int, meas: dict[str, Any], tr: TrackRows, rec: Recording,
                 cfg: dict[str, Any], config_path: str) -> TmaSolution | None:
    """One track's solution, or None (with a warning) when its rows are too few or too
    short."""
    method = track_method(meas, cfg)
    if method == "bearings_frequency":
        f = meas.get("freq")
        if f is None or not np.any(np.isfinite(f)):
            warnings.warn(f"track {tid}: no line frequencies: not solved by "
                          "bearings_frequency", stacklevel=3)
            return None
    if method == "delays":
        meas = _delays_rows(tr, meas, config_path)
    t = meas["time"]
    if t.size < cfg["min_rows"] or (t.size and t[-1] - t[0] < cfg["min_duration_s"]):
        dur = float(t[-1] - t[0]) if t.size else 0.0
        why = (f"fewer than tma.min_rows = {cfg['min_rows']}" if t.size < cfg["min_rows"]
               else f"shorter than tma.min_duration_s = {cfg['min_duration_s']:g} s")
        warnings.warn(f"track {tid}: {t.size} rows over {dur:.0f} s, {why}: not solved",
                      stacklevel=3)
        return None
    if method == "bearings" and meas.get("azimuth") is not None:
        cfg = dict(cfg, side="starboard")  # azimuths: port = starboard = the one bearing
    try:
        return solve_window(meas, rec, dict(cfg, method=method), float(t[0]), float(t[-1]))
    except ValueError as e:
        raise FormatError(f"{tr.products}: track {tid}: {e}") from None


def run_tracks_tma(tracks_path: str, config_path: str, output_path: str,
                   progress: bool = False) -> list[tuple[int, TmaSolution]]:
    """Solve one batch TMA per confirmed track of a tracks file and write a ``tma`` group.

    Parameters
    ----------
    tracks_path : str
        Tracks file (multi-target tracker, bearings).
    config_path : str
        TMA TOML (``arrayproc/data/tma/tracks.toml``; keys: :data:`.run.PARAMS`).
    output_path : str
        Products file to write (one ``tma`` group with ``track_id``).
    progress : bool
        One line per solution on stderr.

    Returns
    -------
    list of (int, TmaSolution)
        Track id and solution, in the order written (each track's preferred solution, then
        its mirror when unresolved: ``sol.mirror`` of the one before).
    """
    cfg = load_tma_config(config_path)
    tr = read_track_rows(tracks_path, cfg)
    if cfg["method"] == "bearings_frequency" and not any(
            m.get("freq") is not None and np.any(np.isfinite(m["freq"]))
            for m in tr.tracks.values()):
        raise ConfigError(f"{config_path}: tma.method = 'bearings_frequency' but no confirmed "
                          f"track of {tracks_path} has line frequencies (use 'bearings' or "
                          "'auto')")
    rec_path = tr.recording or as_text(read_products(tr.products)["/"].get("source", ""))
    if not rec_path:
        raise ConfigError(f"{config_path}: tma.recording is needed (the tracks file names no "
                          "recording)")
    rec_path = resolve_beside(rec_path, config_path if cfg["recording"] else tracks_path)
    if not os.path.exists(rec_path):
        raise FormatError(f"{tracks_path}: the recording {rec_path} does not exist")
    sols: list[TmaSolution] = []
    ids: list[int] = []
    with Recording(rec_path) as rec:
        for tid, meas in tr.tracks.items():
            sol = _solve_track(tid, meas, tr, rec, cfg, config_path)
            if sol is None:
                continue
            warn_if_far(sol, rec, cfg, f"{tracks_path}: track {tid}")
            for s in with_unresolved_mirrors([sol], cfg["mirror_chi2"],
                                             f"{tracks_path}: track {tid}"):
                sols.append(s)
                ids.append(tid)
            if progress:
                _log.info(f"tma track {tid} {sol.method}: x {sol.state[0]:9.1f} y "
                          f"{sol.state[1]:9.1f} m, course {sol.heading_deg:5.1f} deg, speed "
                          f"{sol.speed_mps:5.2f} m/s, range σ {sol.range_sigma:8.1f} m")
    if not sols:
        raise FormatError(f"{tracks_path}: no confirmed track with tma.min_rows = "
                          f"{cfg['min_rows']} rows over tma.min_duration_s = "
                          f"{cfg['min_duration_s']:g} s")
    write_tma(output_path, sols, rec_path, cfg,
              root_attrs={"products": os.path.abspath(tr.products),
                          "tracks": os.path.abspath(tracks_path)},
              track_ids=ids, measurements=tr.group, products=os.path.abspath(tr.products),
              tracks=os.path.abspath(tracks_path))
    return list(zip(ids, sols, strict=True))
