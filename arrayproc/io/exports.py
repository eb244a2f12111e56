"""Exchange formats: Raven selection tables and Debrief replay (REP) files.

**Raven selection table** (Cornell Lab of Ornithology, *Raven Pro 1.6 User's Manual*, ch. 6
"Selection tables"): a tab-separated text file, first line the column names. The standard
columns written are ``Selection`` (1-based), ``View`` ("Spectrogram 1"), ``Channel`` (1-based),
``Begin Time (s)``, ``End Time (s)``, ``Low Freq (Hz)``, ``High Freq (Hz)``, and for a list of
consecutive recordings ``Begin File`` and ``File Offset (s)``: times are cumulative over the
files in the order given (file k starts at the summed durations of files 0..k−1), the offset is
the time inside ``Begin File``. Our columns follow under their products names (``snr_db``,
``cone_deg`` …). ``detections`` rows give their own times and band; a ``bearings`` row (the
centre of an integration window) spans half the scan period either side.

**Debrief REP** (Debrief 3 user guide, "Replay file format"): one line per fix,

    YYMMDD HHMMSS.SSS NAME SYM DD MM SS.SS H DDD MM SS.SS H COURSE SPEED DEPTH

(course deg true, speed kn, depth m) for tracks and ownship, and for bearings

    ;SENSOR2: YYMMDD HHMMSS.SSS OWNSHIP SYM NULL BEARING AMBIG FREQ NULL SENSOR LABEL

(bearing and ambiguous bearing in deg true, frequency in Hz, sensor position NULL: Debrief
takes it from the ownship track). World x east / y north metres are turned into latitude and
longitude on a sphere of radius 6 371 008.8 m about an origin (local tangent plane; 0.01″
≈ 0.3 m of rounding). :func:`read_rep` reads both line types back.

Written here: both formats are plain text with no maintained Python writer.
"""

from __future__ import annotations

import csv
import datetime as dt
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from arrayproc.errors import FormatError
from arrayproc.io.text import as_text

EARTH_RADIUS_M = 6371008.8
KNOT = 1852.0 / 3600.0
RAVEN_COLUMNS = ("Selection", "View", "Channel", "Begin Time (s)", "End Time (s)",
                 "Low Freq (Hz)", "High Freq (Hz)", "Begin File", "File Offset (s)")
_EXTRA = ("snr_db", "level_db", "cone_deg", "bearing_port_deg", "bearing_stbd_deg", "spl_db")


def _recording_info(root: dict, path: str) -> tuple[str, float | None, str | None, str]:
    """(recording path, duration s or None, ISO start time or None, file name for Raven)."""
    src = as_text(root.get("source", root.get("recording", "")))
    if not src:
        return "", None, None, os.path.basename(path)
    if not os.path.isabs(src) and not os.path.exists(src):
        cand = os.path.join(os.path.dirname(os.path.abspath(path)), src)
        src = cand if os.path.exists(cand) else src
    name = os.path.basename(src)
    if not os.path.exists(src):
        return src, None, None, name
    from arrayproc.io.recording import Recording
    try:
        with Recording(src, require_geometry=False) as rec:
            dur = float(rec.duration)
            start = rec.start_time
    except (OSError, FormatError):
        return src, None, None, name
    import h5py
    with h5py.File(src, "r") as f:
        imp = as_text(f.attrs.get("imported_from", ""))
    if imp and "," not in imp:
        name = imp  # the WAV a Raven user opens
    return src, dur, start, name


def raven_rows(paths: Sequence[str]) -> list[dict[str, object]]:
    """Raven selection rows from ``detections`` and ``bearings`` groups of products files
    given in time order (consecutive recordings).

    Parameters
    ----------
    paths : sequence of str
        Products files.

    Returns
    -------
    list of dict
        One dict per selection with the Raven columns and ours.
    """
    from arrayproc.io.products import read_products

    rows: list[dict[str, object]] = []
    offset = 0.0
    for path in paths:
        prod = read_products(path)
        _src, dur, _start, fname = _recording_info(prod["/"], path)
        found = False
        t_end_file = 0.0
        for gname, g in prod.items():
            if gname == "/":
                continue
            kind = g.kind
            if kind == "detections":
                for k in ("time_start", "time_end", "freq_lo", "freq_hi"):
                    if k not in g:
                        raise FormatError(f"{path}: detections column {k!r} is missing")
                t0 = np.asarray(g["time_start"], float)
                t1 = np.asarray(g["time_end"], float)
                ch = np.asarray(g.get("channel", np.zeros(t0.size)), np.int64) + 1
            elif kind == "bearings":
                if "time" not in g:
                    raise FormatError(f"{path}: bearings column 'time' is missing")
                t = np.asarray(g["time"], float)
                ut = np.unique(t)
                half = 0.5 * float(np.median(np.diff(ut))) if ut.size > 1 else 0.5
                t0, t1 = t - half, t + half
                ch = np.ones(t.size, np.int64)
            else:
                continue
            found = True
            lo = np.asarray(g.get("freq_lo", np.full(t0.size, np.nan)), float)
            hi = np.asarray(g.get("freq_hi", np.full(t0.size, np.nan)), float)
            t0 = np.maximum(t0, 0.0)
            t_end_file = max(t_end_file, float(t1.max()) if t1.size else 0.0)
            extra = [k for k in _EXTRA if k in g]
            for i in np.argsort(t0, kind="stable"):
                r: dict[str, object] = {
                    "View": "Spectrogram 1", "Channel": int(ch[i]),
                    "Begin Time (s)": offset + float(t0[i]),
                    "End Time (s)": offset + float(t1[i]),
                    "Low Freq (Hz)": float(lo[i]), "High Freq (Hz)": float(hi[i]),
                    "Begin File": fname, "File Offset (s)": float(t0[i]),
                    "kind": kind, "group": gname}
                for k in extra:
                    r[k] = float(np.asarray(g[k], float)[i])
                rows.append(r)
        if not found:
            raise FormatError(f"{path}: no detections or bearings group to export")
        offset += dur if dur is not None else t_end_file
    rows.sort(key=lambda r: (r["Begin Time (s)"], r["Channel"]))
    for k, r in enumerate(rows, 1):
        r["Selection"] = k
    return rows


def write_raven(paths: Sequence[str], out: str) -> int:
    """Write a Raven selection table (tab-separated) for products files ``paths``; returns the
    number of selections."""
    rows = raven_rows(paths)
    extra = [k for k in ("kind", "group", *_EXTRA) if any(k in r for r in rows)]
    cols = list(RAVEN_COLUMNS) + extra
    with open(out, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh, delimiter="\t", lineterminator="\n")
        w.writerow(cols)
        for r in rows:
            w.writerow([_fmt(r.get(c, "")) for c in cols])
    return len(rows)


def _fmt(v: object) -> str:
    if isinstance(v, float):
        return "" if not math.isfinite(v) else f"{v:.6f}"
    return str(v)


def read_raven(path: str) -> list[dict[str, str]]:
    """Read a selection table back: one dict per row keyed by the header's column names."""
    with open(path, newline="", encoding="utf-8") as fh:
        r = csv.DictReader(fh, delimiter="\t")
        if r.fieldnames is None or "Selection" not in r.fieldnames:
            raise FormatError(f"{path}: not a Raven selection table (no 'Selection' column)")
        return list(r)


# ----------------------------------------------------------------------------- REP

def xy_to_latlon(x: np.ndarray, y: np.ndarray, origin: tuple[float, float]
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Local east/north metres to latitude/longitude (deg) about ``origin`` (lat, lon)."""
    lat0, lon0 = origin
    lat = lat0 + np.degrees(np.asarray(y, float) / EARTH_RADIUS_M)
    lon = lon0 + np.degrees(np.asarray(x, float) / (EARTH_RADIUS_M * math.cos(
        math.radians(lat0))))
    return lat, lon


def latlon_to_xy(lat: np.ndarray, lon: np.ndarray, origin: tuple[float, float]
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Inverse of :func:`xy_to_latlon`."""
    lat0, lon0 = origin
    y = np.radians(np.asarray(lat, float) - lat0) * EARTH_RADIUS_M
    x = np.radians(np.asarray(lon, float) - lon0) * EARTH_RADIUS_M * math.cos(
        math.radians(lat0))
    return x, y


def _dms(v: float, pos: str, neg: str, width: int) -> str:
    h = pos if v >= 0 else neg
    a = abs(v)
    d = int(a)
    m = int((a - d) * 60)
    s = (a - d - m / 60) * 3600
    if s >= 59.995:  # rounding would print 60.00
        s = 0.0
        m += 1
        if m == 60:
            m, d = 0, d + 1
    return f"{d:0{width}d} {m:02d} {s:05.2f} {h}"


def _when(start: dt.datetime, t: float) -> str:
    w = start + dt.timedelta(seconds=float(t))
    return w.strftime("%y%m%d %H%M%S") + f".{w.microsecond // 1000:03d}"


def _start(iso: str | None) -> dt.datetime:
    if not iso:
        return dt.datetime(2000, 1, 1, tzinfo=dt.timezone.utc)
    try:
        return dt.datetime.fromisoformat(iso.replace("Z", "+00:00"))
    except ValueError:
        raise FormatError(f"start time {iso!r} is not ISO-8601") from None


def _fix(name: str, sym: str, start: dt.datetime, t: float, x: float, y: float, vx: float,
         vy: float, origin: tuple[float, float], depth: float = 0.0) -> str:
    lat, lon = xy_to_latlon(np.array([x]), np.array([y]), origin)
    course = math.degrees(math.atan2(vx, vy)) % 360.0
    speed = math.hypot(vx, vy) / KNOT
    return (f"{_when(start, t)} {name} {sym} {_dms(float(lat[0]), 'N', 'S', 2)} "
            f"{_dms(float(lon[0]), 'E', 'W', 3)} {course:.1f} {speed:.2f} {depth:.1f}")


def write_rep(path: str, out: str, origin: tuple[float, float] = (0.0, 0.0),
              confirmed_only: bool = True) -> int:
    """Write a Debrief REP file from a ``tracks`` file (tracks and the ownship) or a
    products file with ``bearings`` (``;SENSOR2:`` lines, ownship from the recording's /nav).

    Parameters
    ----------
    path : str
        Tracks or products file.
    out : str
        REP file to write.
    origin : (float, float)
        Latitude, longitude (deg) of the world frame's origin.
    confirmed_only : bool
        Tracks: write only rows with status confirmed.

    Returns
    -------
    int
        Lines written.
    """
    from arrayproc.io.products import read_products

    prod = read_products(path)
    root = prod["/"]
    _src, _dur, start_iso, _ = _recording_info(root, path)
    lines = [f";; arrayproc export of {os.path.basename(path)}; origin {origin[0]:.6f} "
             f"{origin[1]:.6f}"]
    groups = {k: g for k in ("tracks", "bearings") for g in prod.groups(k).values()}  # the last
    if "tracks" in groups:
        if not start_iso:
            rec = as_text(root.get("recording", ""))
            if rec and os.path.exists(rec):
                from arrayproc.io.recording import Recording
                with Recording(rec, require_geometry=False) as r:
                    start_iso = r.start_time
        start = _start(start_iso)
        g = groups["tracks"]
        t = np.asarray(g["time"], float)
        tid = np.asarray(g["track_id"], np.int64)
        keep = np.ones(t.size, bool)
        if confirmed_only and "status" in g:
            st = np.asarray(g["status"])
            keep = (st == 1) if st.dtype.kind in "iu" else np.array(
                [as_text(s) == "confirmed" for s in st])  # io.schema code 1: confirmed
        if "own_x" in g:
            ot, idx = np.unique(t, return_index=True)
            ox = np.asarray(g["own_x"], float)[idx]
            oy = np.asarray(g["own_y"], float)[idx]
            vx = np.gradient(ox, ot) if ot.size > 1 else np.zeros(1)
            vy = np.gradient(oy, ot) if ot.size > 1 else np.zeros(1)
            for k in range(ot.size):
                lines.append(_fix("OWNSHIP", "@A", start, ot[k], ox[k], oy[k], vx[k], vy[k],
                                  origin))
        for i in np.flatnonzero(keep):
            lines.append(_fix(f"TRACK_{tid[i]}", "@C", start, t[i], float(g["x"][i]),
                              float(g["y"][i]), float(g["vx"][i]), float(g["vy"][i]), origin))
    elif "bearings" in groups:
        start = _start(start_iso)
        g = groups["bearings"]
        t = np.asarray(g["time"], float)
        port = np.asarray(g["bearing_port_deg"], float)
        stbd = np.asarray(g["bearing_stbd_deg"], float)
        f = 0.5 * (np.asarray(g.get("freq_lo", np.full(t.size, np.nan)), float)
                   + np.asarray(g.get("freq_hi", np.full(t.size, np.nan)), float))
        rec = _src
        if rec and os.path.exists(rec):
            from arrayproc.io.recording import Recording
            with Recording(rec, require_geometry=False) as r:
                nav = r.nav
            ut = np.unique(t)
            pos, hd, _, _ = nav.at(ut)
            v = np.gradient(pos, ut, axis=0) if ut.size > 1 else np.zeros((1, 2))
            for k in range(ut.size):
                lines.append(_fix("OWNSHIP", "@A", start, ut[k], pos[k, 0], pos[k, 1], v[k, 0],
                                  v[k, 1], origin))
        for i in np.argsort(t, kind="stable"):
            fr = "NULL" if not math.isfinite(f[i]) else f"{f[i]:.1f}"
            lines.append(f";SENSOR2: {_when(start, t[i])} OWNSHIP @B NULL {stbd[i]:.1f} "
                         f"{port[i]:.1f} {fr} NULL TowedArray B{i}")
    else:
        raise FormatError(f"{path}: no tracks or bearings group to export")
    with open(out, "w", encoding="utf-8") as fh:
        fh.write("\n".join(lines) + "\n")
    return len(lines)


@dataclass
class RepData:
    """Parsed REP content: ``tracks`` {name: arrays time (s since ``start``), x, y (m), course
    (deg), speed (m/s), depth (m)} and ``sensor`` lines {time, track, bearing, ambiguous,
    freq}."""

    start: dt.datetime
    tracks: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)
    sensor: dict[str, np.ndarray] = field(default_factory=dict)


def _parse_when(d: str, t: str) -> dt.datetime:
    fmt = "%y%m%d" if len(d) == 6 else "%Y%m%d"
    day = dt.datetime.strptime(d, fmt).replace(tzinfo=dt.timezone.utc)
    hh, mm, ss = int(t[0:2]), int(t[2:4]), float(t[4:])
    return day + dt.timedelta(hours=hh, minutes=mm, seconds=ss)


def _null(v: str) -> float:
    return math.nan if v.upper() in ("NULL", "NAN") else float(v)


def read_rep(path: str, origin: tuple[float, float] = (0.0, 0.0)) -> RepData:
    """Read track fixes and ``;SENSOR2:`` lines of a REP file (comments and other ``;``
    lines skipped); positions in metres about ``origin`` (lat, lon deg), times in s from the
    first line's time."""
    fixes: dict[str, list[tuple]] = {}
    sens: list[tuple] = []
    first: dt.datetime | None = None
    with open(path, encoding="utf-8") as fh:
        for no, line in enumerate(fh, 1):
            s = line.strip()
            if not s or (s.startswith(";") and not s.startswith(";SENSOR2:")):
                continue
            p = s.split()
            try:
                if p[0] == ";SENSOR2:":
                    when = _parse_when(p[1], p[2])
                    if p[5].upper() == "NULL":
                        rest = p[6:]
                    else:
                        rest = p[13:]
                    sens.append((when, p[3], _null(rest[0]), _null(rest[1]), _null(rest[2])))
                else:
                    when = _parse_when(p[0], p[1])
                    lat = (int(p[4]) + int(p[5]) / 60 + float(p[6]) / 3600) * (
                        1 if p[7] == "N" else -1)
                    lon = (int(p[8]) + int(p[9]) / 60 + float(p[10]) / 3600) * (
                        1 if p[11] == "E" else -1)
                    fixes.setdefault(p[2], []).append(
                        (when, lat, lon, float(p[12]), float(p[13]) * KNOT, float(p[14])))
            except (IndexError, ValueError):
                raise FormatError(f"{path}:{no}: not a REP fix or ;SENSOR2: line") from None
            first = when if first is None or when < first else first
    if first is None:
        raise FormatError(f"{path}: no REP lines")
    out = RepData(first)
    for name, fx in fixes.items():
        x, y = latlon_to_xy(np.array([f[1] for f in fx]), np.array([f[2] for f in fx]), origin)
        out.tracks[name] = {
            "time": np.array([(f[0] - first).total_seconds() for f in fx]), "x": x, "y": y,
            "course": np.array([f[3] for f in fx]), "speed": np.array([f[4] for f in fx]),
            "depth": np.array([f[5] for f in fx])}
    if sens:
        out.sensor = {"time": np.array([(r[0] - first).total_seconds() for r in sens]),
                      "track": np.array([r[1] for r in sens]),
                      "bearing": np.array([r[2] for r in sens]),
                      "ambiguous": np.array([r[3] for r in sens]),
                      "freq": np.array([r[4] for r in sens])}
    return out


__all__ = ["write_raven", "read_raven", "raven_rows", "write_rep", "read_rep", "RepData",
           "xy_to_latlon", "latlon_to_xy", "RAVEN_COLUMNS"]
