"""``[tracker] mode = "multi"``: every target of a products file held as a track.

Three measurement kinds, one :class:`~arrayproc.track.manage.manager.TrackManager` each:

- ``bearings`` (towed line array): a bearing / bearing-rate filter per track (nearly
  constant rate, BLK 2001 eq. 6.2.2-12, R from σ_cone / sin θ, the beam widening towards
  end-fire, thesis eq. 2.9): by default (``space = "bearing"``) a mirrored pair of
  true-bearing hypotheses weighted by their likelihoods
  (:mod:`arrayproc.track.manage.mirrored`), which coasts through ownship turns; or
  (``space = "cone"``) one filter in cone-angle space, where a line array's measurement is
  unambiguous but swings in turns. Rows of one scan closer than ``merge_deg`` (the broadband
  peak and the tonal lines of one source) form one measurement, its strongest row. Each track's rows
  then drive a TMA filter — by default the UKF with left-right resolution (L-R paper
  eqs. (9)-(13)), any filter of ``FILTERS`` by ``filter`` — from the same ``[tracker]`` keys as
  single mode.
- ``contacts`` (active): Cartesian CV tracks, EKF with the bearing-range-range-rate model
  (:mod:`arrayproc.track.models.bearing_range_rate`). A line array's contact has two
  candidate bearings (port, starboard); both enter as measurements (``mirror = true``), so a
  ghost track forms on the mirror side and dies when the ownship turns.
- ``positions`` (compact array): 3-D CV tracks, Kalman filter with each row's ``cov``.

Config (``[tracker]`` keys beside those of single mode)::

    mode = "multi"
    measurements = "bearings"     # bearings | contacts | positions
    association = "gnn"           # gnn | jpda
    gate_prob = 0.999             # P_G
    confirm = [3, 5]              # M of N
    max_misses = 5                # consecutive missed scans of a confirmed track
    hit_window = [3, 15]          # optional: delete a confirmed track with < 3 hits in 15 scans
    pd = 0.9                      # JPDA detection probability
    clutter_density = 1e-3        # JPDA, false measurements per unit of measurement space
    [tracker.bearing]             # the bearing tracker
    space = "bearing"             # bearing (mirrored hypotheses) | cone
    sigma_cone_deg = 0.7          # at broadside
    q_bearing = 0.002             # deg²/s³ (space = "bearing")
    turn_ref_deg_s = 0.1          # Q × (1 + (heading rate / turn_ref)²)
    q_cone = 0.05                 # deg²/s³ (space = "cone")
    merge_deg = 4.0
    sigma_rate_deg_s = 0.5        # initial cone-rate σ
    merge_d2 = 4.0                # duplicate confirmed tracks (d² of the cone states)
    [tracker.contacts]
    sigma_bearing_deg = 2.0
    sigma_range_m = 20.0
    sigma_range_rate_mps = 0.3
    q = 0.01                      # m²/s³
    sigma_speed_mps = 5.0         # unobserved tangential speed at initiation
    mirror = true
    moving_only = false           # only contacts flagged moving enter (still clutter never does)
    min_snr_db = 0.0              # only contacts with snr_db at least this enter (0: all)
    [tracker.positions]
    q = 0.01
    sigma_speed_mps = 5.0
"""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

from arrayproc.config import read_toml, resolve_beside
from arrayproc.errors import ConfigError, FormatError
from arrayproc.geo.nav import Nav
from arrayproc.io.text import as_text
from arrayproc.track.filters.stacked import StackedEKF
from arrayproc.track.manage.delete import DeletionRule
from arrayproc.track.manage.initiate import MofN
from arrayproc.track.manage.manager import TrackManager
from arrayproc.track.manage.tracks import STATUS_CODES, Status, Track, status_names
from arrayproc.track.models.frame import ObserverRelative
from arrayproc.track.models.motion import ConstantVelocity
from arrayproc.track.models.position import ConeAngle, Position
from arrayproc.track.state import Context

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

MULTI_KEYS = {"mode", "measurements", "association", "gate_prob", "confirm", "max_misses",
              "hit_window",
              "pd", "clutter_density", "bearing", "contacts", "positions"}
_SUB = {
    "bearing": {"space": "bearing", "sigma_cone_deg": 0.7, "q_cone": 0.05,
                "q_bearing": 0.002, "turn_ref_deg_s": 0.1, "merge_deg": 4.0,
                "sigma_rate_deg_s": 0.5, "merge_d2": 4.0, "min_sigma_sin": 0.2},
    "contacts": {"sigma_bearing_deg": 2.0, "sigma_range_m": 20.0, "sigma_range_rate_mps": 0.3,
                 "q": 0.01, "sigma_speed_mps": 5.0, "mirror": True, "moving_only": False,
                 "min_snr_db": 0.0},
    "positions": {"q": 0.01, "sigma_speed_mps": 5.0},
}


def tracker_mode(path: str) -> str:
    """``[tracker] mode`` of a tracker TOML ("single" when absent); errors are left to the
    full validation."""
    try:
        with open(path, "rb") as fh:
            doc = tomllib.load(fh)
    except (OSError, tomllib.TOMLDecodeError, UnicodeDecodeError):
        return "single"
    t = doc.get("tracker")
    return str(t.get("mode", "single")) if isinstance(t, dict) else "single"


def _num(path: str, key: str, v: Any, lo: float = 0.0, strict: bool = True) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) \
            or v < lo or (strict and v == lo):
        raise ConfigError(f"{path}: tracker.{key} must be a number "
                          f"{'>' if strict else '>='} {lo}")
    return float(v)


def split_config(path: str) -> tuple[dict[str, Any], dict[str, Any]]:
    """Read a multi-mode tracker TOML: (multi settings, the single-mode keys for the TMA
    filter, validated by :func:`arrayproc.track.single.load_single_config`)."""
    import tempfile

    from arrayproc.track.single import load_single_config
    doc, _ = read_toml(path, "tracker")
    t = doc.get("tracker")
    if not isinstance(t, dict):
        raise ConfigError(f"{path}: missing [tracker] table")
    multi = {k: t[k] for k in MULTI_KEYS if k in t}
    single = {k: v for k, v in t.items() if k not in MULTI_KEYS}
    cfg: dict[str, Any] = {"measurements": multi.get("measurements", "bearings"),
                           "association": multi.get("association", "gnn")}
    if cfg["measurements"] not in ("bearings", "contacts", "positions"):
        raise ConfigError(f"{path}: tracker.measurements must be bearings, contacts or "
                          f"positions, not {cfg['measurements']!r}")
    if cfg["association"] not in ("gnn", "jpda"):
        raise ConfigError(f"{path}: tracker.association must be gnn or jpda")
    gp = _num(path, "gate_prob", multi.get("gate_prob", 0.999))
    if gp >= 1:
        raise ConfigError(f"{path}: tracker.gate_prob must be < 1")
    cfg["gate_prob"] = gp
    conf = multi.get("confirm", [3, 5])
    if (not isinstance(conf, list) or len(conf) != 2
            or not all(isinstance(v, int) and not isinstance(v, bool) for v in conf)
            or not 1 <= conf[0] <= conf[1]):
        raise ConfigError(f"{path}: tracker.confirm must be [M, N] integers, 1 <= M <= N")
    cfg["confirm"] = MofN(conf[0], conf[1])
    mm = multi.get("max_misses", 5)
    if isinstance(mm, bool) or not isinstance(mm, int) or mm < 1:
        raise ConfigError(f"{path}: tracker.max_misses must be an integer >= 1")
    cfg["max_misses"] = mm
    hw = multi.get("hit_window", None)
    if hw is not None and (not isinstance(hw, list) or len(hw) != 2
                           or not all(isinstance(v, int) and not isinstance(v, bool)
                                      for v in hw) or not 1 <= hw[0] <= hw[1]):
        raise ConfigError(f"{path}: tracker.hit_window must be [K, W] integers, 1 <= K <= W "
                          "(delete a confirmed track with fewer than K hits in W scans)")
    cfg["hit_window"] = hw
    pd = _num(path, "pd", multi.get("pd", 0.9))
    if pd > 1:
        raise ConfigError(f"{path}: tracker.pd must be <= 1")
    cfg["pd"] = pd
    cfg["clutter_density"] = _num(path, "clutter_density", multi.get("clutter_density", 1e-3))
    for sub, defaults in _SUB.items():
        given = multi.get(sub, {})
        if not isinstance(given, dict):
            raise ConfigError(f"{path}: tracker.{sub} must be a table")
        vals = dict(defaults)
        for k, v in given.items():
            if k not in defaults:
                raise ConfigError(f"{path}: unknown key tracker.{sub}.{k}")
            if isinstance(defaults[k], bool):
                if not isinstance(v, bool):
                    raise ConfigError(f"{path}: tracker.{sub}.{k} must be true or false")
                vals[k] = v
            elif k == "space":
                if v not in ("cone", "bearing"):
                    raise ConfigError(f"{path}: tracker.bearing.space must be 'cone' or "
                                      f"'bearing', not {v!r}")
                vals[k] = v
            else:
                vals[k] = _num(path, f"{sub}.{k}", v)
        cfg[sub] = vals
    # the TMA filter's keys go through the single-mode validator (same messages)
    with tempfile.NamedTemporaryFile("w", suffix=".toml", delete=False) as fh:
        tmp = fh.name
        fh.write(_toml_table("tracker", single))
    try:
        tma = load_single_config(tmp)
    except ConfigError as e:
        raise ConfigError(str(e).replace(tmp, path)) from None
    finally:
        Path(tmp).unlink(missing_ok=True)
    return cfg, tma


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(v)
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise ConfigError(f"tracker: unsupported value {v!r}")


def _toml_table(name: str, d: dict[str, Any]) -> str:
    lines = [f"[{name}]"]
    subs = []
    for k, v in d.items():
        if isinstance(v, dict):
            subs.append(_toml_table(f"{name}.{k}", v))
        else:
            lines.append(f"{k} = {_toml_value(v)}")
    return "\n".join(lines + subs) + "\n"


# ----------------------------------------------------------------------------- bearings

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


def _window(cfg: dict[str, Any]) -> dict[str, Any]:
    hw = cfg.get("hit_window")
    return {} if hw is None else {"window": int(hw[1]), "min_hits": int(hw[0])}


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

    mgr = TrackManager(filt, init, association=cfg["association"], gate_prob=cfg["gate_prob"],
                       confirm=cfg["confirm"],
                       delete=DeletionRule(max_misses=cfg["max_misses"], **_window(cfg), pos=pos,
                                           merge_d2=float(b["merge_d2"])),
                       pd=cfg["pd"], clutter_density=cfg["clutter_density"])
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


def tma_track(tr: Track, b: dict[str, np.ndarray], nav: Nav, tma_cfg: dict[str, Any],
              by_side: bool = False) -> dict[str, np.ndarray] | None:
    """TMA of one cone track: its rows' port/starboard bearings through the configured filter
    (UKF with left-right resolution by default) from its first row — the two hypotheses fed
    by side (``by_side``, starboard and port members) or by continuity
    (:func:`~arrayproc.track.single.assign_by_continuity`); between rows (coasting)
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
    if tma_cfg["lr"] and by_side:
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


# ----------------------------------------------------------------------------- contacts

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

    return TrackManager(filt, init, association=cfg["association"], gate_prob=cfg["gate_prob"],
                        confirm=cfg["confirm"],
                        delete=DeletionRule(max_misses=cfg["max_misses"], **_window(cfg),
                                            pos=(0, 1)),
                        pd=cfg["pd"], clutter_density=cfg["clutter_density"])


def positions_manager(cfg: dict[str, Any]) -> TrackManager:
    """Track manager for ``positions``: 3-D CV Kalman filter with each row's covariance (the
    scan context)."""
    pc = cfg["positions"]
    filt = StackedEKF(ConstantVelocity(q1=float(pc["q"]), axes=3), Position(axes=3))
    sv = float(pc["sigma_speed_mps"])

    def init(Z: np.ndarray, t: float, ctx: Context, j: int) -> tuple[np.ndarray, np.ndarray]:
        P = np.zeros((6, 6))
        P[:3, :3] = ctx.meas_cov[j]
        P[3:, 3:] = sv * sv * np.eye(3)
        return np.r_[Z[j], 0.0, 0.0, 0.0], P

    return TrackManager(filt, init, association=cfg["association"], gate_prob=cfg["gate_prob"],
                        confirm=cfg["confirm"],
                        delete=DeletionRule(max_misses=cfg["max_misses"], **_window(cfg),
                                            pos=(0, 1, 2)),
                        pd=cfg["pd"], clutter_density=cfg["clutter_density"])


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


# ----------------------------------------------------------------------------- runner

def _group(prod: dict, kind: str, products_path: str, name: str | None = None) -> dict:
    groups = [n for n, g in prod.items() if n != "/" and as_text(g.get("kind")) == kind]
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
    out: list[dict[str, np.ndarray]] = []
    if kind == "bearings":
        g = _group(prod, "bearings", products_path, tma_cfg.get("bearings"))
        b = _columns(g, ("time", "cone_deg", "bearing_port_deg", "bearing_stbd_deg"),
                     products_path)
        score = np.asarray(g.get("snr_db", g.get("level_db", np.zeros_like(b["time"]))), float)
        ok = np.isfinite(b["time"]) & np.isfinite(b["cone_deg"])
        if "cone_gate" in tma_cfg:
            lo, hi = tma_cfg["cone_gate"]
            ok &= (b["cone_deg"] >= lo) & (b["cone_deg"] <= hi)
        idx = np.flatnonzero(ok)
        scans = bearing_scans(b["time"][idx], b["cone_deg"][idx],
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
    if kind == "contacts":
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
              progress: bool = False) -> None:
    """``arrayproc track PRODUCTS.h5 -c TRACKER.toml -o TRACKS.h5`` with ``mode = "multi"``:
    writes one ``tracks`` group, one row per track per scan of its life (status tentative,
    confirmed or deleted)."""
    import os

    from arrayproc.io.products import ProductsWriter, read_products
    from arrayproc.track.single import _read_nav

    cfg, tma_cfg = split_config(config_path)
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
    tracks, rows = multi_target(products_path, cfg, tma_cfg, nav)
    if progress:
        n_conf = sum(tr.confirmed_at is not None for tr in tracks)
        print(f"{len(tracks)} tracks, {n_conf} confirmed", file=sys.stderr)
    cfg_text = Path(config_path).read_text(encoding="utf-8", errors="replace")
    with ProductsWriter(out_path, source=str(products_path), chain=cfg_text,
                        attrs={"recording": str(rec)}) as w:
        g = w.group("tracks", "tracks", stage="track", mode="multi",
                    measurements=cfg["measurements"], association=cfg["association"],
                    filter=tma_cfg["filter"], lr=bool(tma_cfg["lr"]))
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


__all__ = ["run_multi", "tracker_mode", "split_config", "multi_target", "bearing_scans",
           "track_cones", "tma_track", "contact_scans", "contacts_manager", "drop_twin_births",
           "positions_manager", "confirmed_status"]
