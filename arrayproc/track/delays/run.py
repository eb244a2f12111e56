"""``arrayproc track DELAYS.h5 -c TRACKER.toml``: the delays rows of a products file and the
recording's poses in, the recursive TDOA track out (a ``tracks`` group). A product with
several rows at one time (a ``tde`` stage keeping several peaks: one row per source) is
tracked by :func:`~arrayproc.track.delays.sources.track_delay_sources` (several tracks, each
with its id and status); one row per time, by the one-source
:func:`~arrayproc.track.delays.tracker.track_delays` (track 1)."""

from __future__ import annotations

import logging
import os
from pathlib import Path
from typing import Any

import numpy as np

from arrayproc.config import resolve_beside
from arrayproc.errors import ConfigError, FormatError
from arrayproc.io.schema import groups_of_kind
from arrayproc.io.text import as_text
from arrayproc.track.delays.config import load_delays_config
from arrayproc.track.delays.sources import track_delay_sources
from arrayproc.track.delays.tracker import track_delays

_log = logging.getLogger(__name__)

__all__ = ["read_delays", "run_delays"]


def read_delays(products_path: str, group: str = "") -> dict[str, Any]:
    """The ``delays`` rows of a products file: ``time`` (B,), ``tau``, ``sigma``, ``corr``
    (B, N) or None, ``reference``, ``group`` and the root ``source``; sorted by time.

    Parameters
    ----------
    products_path : str
        Products file.
    group : str
        Group name ("" : the only group of kind ``delays``).

    Returns
    -------
    dict
    """
    from arrayproc.io.products import delays_columns, read_products

    if not os.path.exists(products_path):
        raise FormatError(f"{products_path}: no such file")
    prod = read_products(products_path)
    names = groups_of_kind(prod, "delays")
    if group:
        if group not in names:
            raise FormatError(f"{products_path}: no delays group {group!r}")
        name = group
    elif not names:
        raise FormatError(f"{products_path}: no delays group")
    elif len(names) > 1:
        raise ConfigError(f"{products_path}: several delays groups ({', '.join(names)}); "
                          "choose one with tracker.delays.group")
    else:
        name = names[0]
    d = delays_columns(prod[name], products_path)
    d.update(group=name, source=as_text(prod["/"].get("source", "")))
    return d


def run_delays(products_path: str, config_path: str, out_path: str,
               progress: bool = False, cfg: dict[str, Any] | None = None
               ) -> dict[str, np.ndarray]:
    """``arrayproc track DELAYS.h5 -c TRACKER.toml -o TRACKS.h5`` with
    ``measurements = "delays"``: one track (id 1, confirmed) from every row, or with several
    rows at one time the tracks of several sources (their ids and statuses), written as a
    ``tracks`` group (``row`` the products row).

    Parameters
    ----------
    products_path : str
        Products file with a ``delays`` group.
    config_path : str
        Tracker TOML (module docstring).
    out_path : str
        Tracks file to write (atomically).
    progress : bool
        One summary line on stderr.
    cfg : dict, optional
        The checked configuration (:func:`~arrayproc.track.delays.config.
        check_delays_config`) when the caller has read the file already.

    Returns
    -------
    dict
        :func:`track_delays`'s result.
    """
    from arrayproc.io.products import ProductsWriter
    from arrayproc.io.recording import Recording
    from arrayproc.track.manage.tracks import STATUS_CODES, Status

    if cfg is None:
        cfg = load_delays_config(config_path)
    d = cfg["delays"]
    meas = read_delays(products_path, d["group"])
    src = cfg["nav"] or meas["source"]
    if not src:
        raise FormatError(f"{products_path}: no root attribute 'source' naming the recording; "
                          "set tracker.nav")
    rec_path = resolve_beside(src, config_path if cfg["nav"] else products_path)
    if not os.path.exists(rec_path):
        raise FormatError(f"{rec_path}: recording with the navigation not found (set "
                          "tracker.nav)")
    t = meas["time"]
    with Recording(rec_path) as rec:
        poses = rec.poses(t)
        c = float(rec.sound_speed)
        if d["array_motion"]:
            from arrayproc.track.batch.motion import nav_velocity
            vel = nav_velocity(rec.nav, t)
        else:
            vel = None
    el = np.stack([p.elements for p in poses]) if len(poses) else np.zeros((0, 0, 3))
    if el.shape[:2] != meas["tau"].shape:
        raise FormatError(f"{products_path}: delays have {meas['tau'].shape[1]} channels but "
                          f"the recording {rec_path} has {el.shape[1]} active channels")
    several = bool(np.any(np.diff(t) == 0))  # several rows at one time: several sources
    run = track_delay_sources if several else track_delays
    res = run(t, meas["tau"], meas["sigma"], el, meas["reference"], c, d, cfg["filter"],
              cfg["params"], heading_rad=np.deg2rad([p.heading for p in poses]),
              corr=meas["corr"], array_velocity=vel)
    if progress:
        r = float(np.hypot(*res["rel"][-1]))
        _log.info(f"delays tracker ({cfg['filter']}, {d['motion']}): {res['time'].size} rows, "
                  f"{int(res['updated'].sum())} updates, final range {r:.1f} m")
    n = res["time"].size
    cfg_text = Path(config_path).read_text(encoding="utf-8", errors="replace")
    with ProductsWriter(out_path, source=str(products_path), chain=cfg_text,
                        attrs={"recording": str(rec_path)}) as w:
        g = w.group("tracks", "tracks", stage="track", mode="multi", measurements="delays",
                    filter=cfg["filter"], motion=d["motion"], lr=len(res["side"]) > 1,
                    array_motion=bool(d["array_motion"]),
                    sides=",".join(res["side"]))
        if several:
            ids = res["track_id"]
            status = np.array([STATUS_CODES[s] for s in res["status"]], np.int8)
        else:
            ids = np.ones(n, np.int64)
            status = np.full(n, STATUS_CODES[Status.CONFIRMED.value], np.int8)
        g.append(time=res["time"], track_id=ids, x=res["x"], y=res["y"],
                 vx=res["vx"], vy=res["vy"], cov=res["cov"], status=status,
                 side_weight=res["side_weight"], own_x=res["own"][:, 0],
                 own_y=res["own"][:, 1],
                 row=np.where(res["updated"], meas["order"][res["row"]], -1).astype(np.int64))
    return res
