"""``arrayproc track``: run a bearings tracker on a products file and write a tracks file.

Reads the ``bearings`` rows of a products file (docs/formats.md) and the array's navigation
from the recording named by the products file's root attribute ``source``
(``/nav``), runs the filter chosen in the tracker TOML — with left-right resolution (L-R paper
eqs. (9)-(13)) when the bearings come from a line array — and writes a ``tracks`` group
(``time``, ``track_id``, ``x``, ``y``, ``vx``, ``vy``, ``cov`` (n, 4, 4), plus the ownship
``own_x``, ``own_y`` used for plotting).

Tracker TOML::

    [tracker]
    filter = "ukf"            # ekf | ukf | ckf | ghf | srf (FILTERS registry)
    lr = true                 # two hypotheses on the port/starboard pair; false: one side
    side = "starboard"        # with lr = false: which column to use (port | starboard)
    model = "cv"              # cv | ct
    sigma_bearing_deg = 1.5
    q1 = 9.0e-6               # m²/s³, eq. (4); default the L-R paper's 1.944e-6 km²/min³
    q2 = 1.75e-12             # rad²/s³, eq. (6)
    range_m = 5000.0          # initialisation prior (Ristic et al. 2003 ch. 6)
    sigma_range_m = 2000.0
    speed_mps = 2.06
    sigma_speed_mps = 1.03
    sigma_course_deg = 51.96
    sigma_turn_deg_s = 0.05
    bearings = "bearings"     # products group (default: the only group of kind bearings)
    nav = "rec.h5"            # optional: recording with /nav (default: the products' source)
    cone_gate = [20.0, 160.0] # optional: only rows with cone angles in [lo, hi] deg
    level = "spl_db"          # optional: received levels from this bearings column (any
                              # filter but srf; level + bearing model, SPL paper eqs. 31-33)
    [tracker.params]          # filter parameters, e.g. alpha/beta/kappa, gh_order, likelihood,
                              # n_particles; and the level model's tl_table, src_depth_m,
                              # rcv_depth_m, sigma_level_db, source_level

One target is tracked: at each time the row with the highest ``snr_db`` (else ``level_db``) is
used. With ``lr``, the two members of each port/starboard pair are assigned to the two
hypotheses by continuity (:func:`assign_by_continuity`), so a target crossing the array's axis
keeps its hypothesis.

The runner only wires components: the configuration gives a motion model
(:mod:`arrayproc.track.models.motion`), a measurement model (bearing, or level + bearing), a
filter (:func:`arrayproc.track.filters.make_filter`) and the L-R resolver
(:class:`arrayproc.track.manage.lr.LRResolver`); the navigation comes from
:class:`arrayproc.io.recording.Recording` and :class:`arrayproc.geo.nav.Nav`.
"""

from __future__ import annotations

import logging
import math
import os
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from arrayproc.config import Param, Schema, read_toml, resolve_beside
from arrayproc.errors import ConfigError, FormatError
from arrayproc.geo.angles import wrap_pi
from arrayproc.geo.nav import Nav
from arrayproc.io.schema import groups_of_kind
from arrayproc.io.text import as_text
from arrayproc.track.filters import FILTERS, FilterDivergence, make_filter
from arrayproc.track.init import TrackPrior, initial_state
from arrayproc.track.manage.lr import LRResolver
from arrayproc.track.models import _kernels as km
from arrayproc.track.models.base import MeasurementModel, MotionModel
from arrayproc.track.models.bearing import Bearing
from arrayproc.track.models.level_bearing import LevelBearing
from arrayproc.track.models.motion import Q1_PAPER, Q2_PAPER, make_model
from arrayproc.track.state import Context
from arrayproc.track.types import legacy_table

_log = logging.getLogger(__name__)

_PRIOR_KEYS = ("range_m", "sigma_range_m", "speed_mps", "sigma_speed_mps", "sigma_course_deg",
               "sigma_turn_deg_s")


def _at_least(lo: float, strict: bool = False) -> Callable[[Any], str | None]:
    def check(v: Any) -> str | None:
        return None if (v > lo if strict else v >= lo) else \
            f"must be a positive number, got {v}"
    return check


def _gate(v: Any) -> str | None:
    return None if 0 <= v[0] < v[1] <= 180 else \
        "must be [lo, hi] cone angles, deg, 0 <= lo < hi <= 180"


#: the ``[tracker]`` keys of the single-target tracker (and of the TMA filter of each
#: multi-target bearing track)
SINGLE_PARAMS = Schema({
    "mode": Param("str", None, "older form of type = \"single\"", choices=("single",)),
    "filter": Param("str", "ukf", "the filter", choices=tuple(FILTERS)),
    "lr": Param("bool", True, "left-right resolution: two hypotheses on the port/starboard "
                "pair"),
    "side": Param("str", None, "with lr = false: the bearing column to track",
                  choices=("port", "starboard")),
    "model": Param("str", "cv", "motion model: cv or ct (constant turn, unknown rate)"),
    "sigma_bearing_deg": Param("float", 1.5, "bearing noise σ", check=_at_least(0, True),
                               unit="deg"),
    "q1": Param("float", Q1_PAPER, "acceleration noise intensity (L-R paper eq. 4)",
                check=_at_least(0), unit="m²/s³"),
    "q2": Param("float", Q2_PAPER, "turn-rate noise intensity (eq. 6)", check=_at_least(0),
                unit="rad²/s³"),
    "bearings": Param("str", None, "the products group (default: the only bearings group)"),
    "nav": Param("str", None, "recording with /nav (default: the products' source)"),
    "params": Param("table", {}, "the filter's parameters"),
    "cone_gate": Param("band", None, "only bearing rows with cone angles in [lo, hi]",
                       check=_gate, unit="deg"),
    "level": Param("str", None, "rpf only: received levels from this bearings column, e.g. "
                   "'spl_db'"),
    "range_m": Param("float", None, "initial range prior", check=_at_least(0, True),
                     unit="m"),
    "sigma_range_m": Param("float", None, "σ of the range prior", check=_at_least(0),
                           unit="m"),
    "speed_mps": Param("float", None, "initial speed prior", check=_at_least(0), unit="m/s"),
    "sigma_speed_mps": Param("float", None, "σ of the speed prior", check=_at_least(0),
                             unit="m/s"),
    "sigma_course_deg": Param("float", None, "σ of the course prior", check=_at_least(0),
                              unit="deg"),
    "sigma_turn_deg_s": Param("float", None, "ct: σ of the turn-rate prior",
                              check=_at_least(0), unit="deg/s"),
}, "the single-target bearings tracker ([tracker] table)")
_KEYS = set(SINGLE_PARAMS)


def load_single_config(path: str) -> dict[str, Any]:
    """Read (once) and check a single-target tracker TOML: :func:`check_single_config` of its
    ``[tracker]`` table."""
    doc, _ = read_toml(path, "tracker")
    return check_single_config(doc.get("tracker"), path)


def check_single_config(t: Any, path: str) -> dict[str, Any]:
    """Check the ``[tracker]`` mapping of a single-target tracker (module doc) and fill in the
    defaults; ConfigError naming the file ``path`` and the key."""
    t = legacy_table(t, path)
    if not isinstance(t, dict):
        raise ConfigError(f"{path}: missing [tracker] table")
    checked = SINGLE_PARAMS.check(t, path, prefix="tracker.")
    # keys without a default stay absent when not given (the runners ask `"side" in cfg`)
    cfg = {k: v for k, v in checked.items() if k in t or SINGLE_PARAMS[k].default is not None}
    cfg["params"] = dict(cfg["params"])
    if not cfg["lr"] and cfg.get("side") not in ("port", "starboard"):
        raise ConfigError(f"{path}: tracker.side must be 'port' or 'starboard' when lr = false")
    if "level" in cfg and cfg["filter"] == "srf":
        raise ConfigError(f"{path}: tracker.level needs a filter that takes any "
                          "measurement model (the srf is bearings-only)")
    return cfg


def _read_bearings(prod: dict, name: str | None, products_path: str,
                   cone_gate: list[float] | None = None,
                   level: str | None = None) -> dict[str, np.ndarray]:
    groups = groups_of_kind(prod, "bearings")
    if name is not None:
        if name not in prod or name == "/":
            raise FormatError(f"{products_path}: no group {name!r}")
        g = prod[name]
    elif len(groups) == 1:
        g = prod[groups[0]]
    elif not groups:
        raise FormatError(f"{products_path}: no bearings group")
    else:
        raise ConfigError(f"{products_path}: several bearings groups ({', '.join(groups)}); "
                          "choose one with tracker.bearings")
    for k in ("time", "bearing_port_deg", "bearing_stbd_deg"):
        if k not in g:
            raise FormatError(f"{products_path}: bearings column {k!r} is missing")
    t = np.asarray(g["time"], float).reshape(-1)
    if level is not None and level not in g:
        raise FormatError(f"{products_path}: bearings column {level!r} (tracker.level) is "
                          "missing")
    names = ("time", "bearing_port_deg", "bearing_stbd_deg", "snr_db", "level_db", "side")
    cols = {k: np.asarray(g[k], float).reshape(-1) for k in
            names + ((level,) if level and level not in names else ()) if k in g}
    if any(v.shape != t.shape for v in cols.values()):
        raise FormatError(f"{products_path}: bearings columns have unequal lengths")
    if t.size == 0:  # a bearings stage that found nothing: a valid empty input
        return cols
    if t.size < 2:
        raise FormatError(f"{products_path}: fewer than two bearing rows")
    ok = np.isfinite(t) & np.isfinite(cols["bearing_port_deg"]) & \
        np.isfinite(cols["bearing_stbd_deg"])
    if not ok.any():
        raise FormatError(f"{products_path}: bearings contain no finite rows")
    if cone_gate is not None:  # keep the contact inside the gate (e.g. out of the tow ship)
        if "cone_deg" not in g:
            raise FormatError(f"{products_path}: bearings column 'cone_deg' is missing "
                              "(needed by tracker.cone_gate)")
        cone = np.asarray(g["cone_deg"], float).reshape(-1)
        ok &= (cone >= cone_gate[0]) & (cone <= cone_gate[1])
        if ok.sum() < 2:
            raise FormatError(f"{products_path}: fewer than two bearing rows inside "
                              f"cone_gate {cone_gate}")
    score = cols.get("snr_db", cols.get("level_db", np.zeros_like(t)))
    score = np.where(np.isfinite(score), score, -np.inf)
    idx = np.flatnonzero(ok)
    # one row per time: the strongest
    order = np.lexsort((-score[idx], t[idx]))
    idx = idx[order]
    first = np.ones(idx.size, bool)
    first[1:] = t[idx][1:] != t[idx][:-1]
    idx = idx[first]
    return {k: v[idx] for k, v in cols.items()}


def _read_nav(path: str) -> Nav:
    """The navigation of a recording (:attr:`arrayproc.io.recording.Recording.nav`; a static
    array at the origin heading north when /nav is absent)."""
    from arrayproc.io.recording import Recording

    if not os.path.exists(path):
        raise FormatError(f"{path}: recording with the navigation not found (set tracker.nav)")
    with Recording(path) as rec:
        return rec.nav


def ownship_states(nav: Nav, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Observer states and headings at the bearing times.

    Parameters
    ----------
    nav : Nav
        The array's navigation.
    t : (K,) ndarray
        Times, s.

    Returns
    -------
    own : (K, 4) ndarray
        [x, y, ẋ, ẏ] (m, m/s): positions from :meth:`Nav.at`; velocities from the fixes'
        central differences, interpolated linearly (zero for a static array).
    heading : (K,) ndarray
        Heading, rad, from :meth:`Nav.at`.
    """
    t = np.asarray(t, dtype=float)
    pos, hd, _, _ = nav.at(t)
    own = np.zeros((t.size, 4))
    own[:, :2] = pos
    if nav.time.size > 1:
        vel = np.gradient(nav.position, nav.time, axis=0)
        for i in range(2):
            own[:, 2 + i] = np.interp(t, nav.time, vel[:, i])
    return own, np.deg2rad(hd)


def assign_by_continuity(port: np.ndarray, stbd: np.ndarray) -> np.ndarray:
    """Two bearing streams (K, 2) rad from port/starboard pairs, each stream a continuous
    history: θ and its mirror 2h − θ (eq. (8)). At each time the pairing of the four
    (member, stream) distances to the streams' linear predictions with the smallest distance
    is kept
    and the other member goes to the other stream: the true bearing moves slowly while its
    mirror swings by twice the heading change, so the true stream anchors the assignment even
    during an ownship turn."""
    z = np.empty((port.size, 2))
    z[0] = port[0], stbd[0]
    for k in range(1, port.size):
        # first-order prediction of each stream (zero-order at the second bearing)
        p0 = z[k - 1, 0] + (km.wrap(z[k - 1, 0] - z[k - 2, 0]) if k > 1 else 0.0)
        p1 = z[k - 1, 1] + (km.wrap(z[k - 1, 1] - z[k - 2, 1]) if k > 1 else 0.0)
        d = [abs(km.wrap(port[k] - p0)), abs(km.wrap(stbd[k] - p1)),
             abs(km.wrap(stbd[k] - p0)), abs(km.wrap(port[k] - p1))]
        z[k] = (port[k], stbd[k]) if int(np.argmin(d)) < 2 else (stbd[k], port[k])
    return z


_LEVEL_KEYS = ("tl_table", "src_depth_m", "rcv_depth_m", "sigma_level_db", "source_level")


def build_components(cfg: dict[str, Any], levels: bool = False
                     ) -> tuple[MotionModel, MeasurementModel, Any, TrackPrior]:
    """Motion model, measurement model, filter and initialisation prior of a tracker config.

    Parameters
    ----------
    cfg : dict
        A :func:`~arrayproc.track.runner.load_tracker_config` result.
    levels : bool
        Use the level + bearing model (SPL paper eqs. (31)-(33)) instead of bearings only.

    Returns
    -------
    motion_model, measurement_model, filter, prior
    """
    motion = make_model(cfg["model"], float(cfg["q1"]), float(cfg["q2"]))
    params = dict(cfg["params"])
    level_params = {k: params.pop(k) for k in _LEVEL_KEYS if k in params}
    sigma = float(cfg["sigma_bearing_deg"])
    meas: MeasurementModel
    if levels:
        meas = LevelBearing(sigma_deg=sigma, **level_params)
    else:
        meas = Bearing(sigma_deg=sigma)
    try:
        filt = make_filter(cfg["filter"], **params)
    except ValueError as e:
        raise ConfigError(f"tracker.params: {e}") from None
    prior = TrackPrior(sigma_bearing_deg=sigma,
                       **{k: float(cfg[k]) for k in _PRIOR_KEYS if k in cfg})
    return motion, meas, filt, prior


def track_bearings(times: np.ndarray, zs_rad: np.ndarray, own: np.ndarray,
                   cfg: dict[str, Any], levels_db: np.ndarray | None = None,
                   heading: np.ndarray | None = None
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Run the configured filter, one hypothesis per column of ``zs_rad``, combined by the L-R
    resolver (eqs. (9)-(13)).

    Parameters
    ----------
    times : (K,) ndarray
        s.
    zs_rad : (K, n_hyp) ndarray
        Bearings, rad; column h feeds hypothesis h.
    own : (K, 4) ndarray
        Observer states (m, m/s).
    cfg : dict
        Tracker configuration (:func:`~arrayproc.track.runner.load_tracker_config`).
    levels_db : (K,) ndarray, optional
        Received levels (dB re 1 µPa): the level + bearing model is used (rows with a
        non-finite level update on the bearing alone).
    heading : (K,) ndarray, optional
        Array heading, rad (context of heading-dependent models).

    Returns
    -------
    xs : (K, n) ndarray
        Combined state (eq. (12)).
    Ps : (K, n, n) ndarray
        Covariance (eq. (13)).
    ws : (K, n_hyp) ndarray
        Weights.
    status : int
        Bit 1 a covariance was repaired, bit 2 a hypothesis diverged, bit 4 every hypothesis
        diverged (the estimate is frozen from then on).
    """
    motion, meas, filt, prior = build_components(cfg, levels_db is not None)
    bearing_only = Bearing(sigma_deg=float(cfg["sigma_bearing_deg"]))
    K, n_hyp = zs_rad.shape
    n = motion.ndim
    xs = np.zeros((K, n))
    Ps = np.zeros((K, n, n))
    ws = np.zeros((K, n_hyp))
    hd = np.zeros(K) if heading is None else np.asarray(heading, float)
    states = [filt.initialize(*initial_state(float(zs_rad[0, h]), own[0], prior, n),
                              t=float(times[0])) for h in range(n_hyp)]
    lr = LRResolver(filt, motion, meas, states)
    status = 0
    for k in range(K):
        if k > 0:
            ctx = Context(own[k], own[k - 1], float(hd[k]), float(times[k]))
            if levels_db is not None and math.isfinite(levels_db[k]):
                zk = [np.array([zs_rad[k, h], levels_db[k]]) for h in range(n_hyp)]
                model = meas
            else:
                zk = [zs_rad[k, h] for h in range(n_hyp)]
                model = bearing_only if levels_db is not None else meas
            try:
                status |= lr.step(float(times[k] - times[k - 1]), ctx, zk, model)
            except FilterDivergence:
                xs[k:], Ps[k:], ws[k:] = xs[k - 1], Ps[k - 1], ws[k - 1]
                return xs, Ps, ws, status | 6
        xs[k], Ps[k], ws[k] = lr.combine()
    return xs, Ps, ws, status


def run_single(products_path: str, config_path: str, out_path: str,
               progress: bool = False, cfg: dict[str, Any] | None = None) -> None:
    """``arrayproc track`` with a single-target tracker (see the module doc); ``cfg`` the
    checked configuration when the caller has read the file already."""
    from arrayproc.io.products import ProductsWriter, read_products
    from arrayproc.io.units import PASCAL, file_units, level_label

    if cfg is None:
        cfg = load_single_config(config_path)
    if not os.path.exists(products_path):
        raise FormatError(f"{products_path}: no such file")
    prod = read_products(products_path)
    units = file_units(prod["/"])
    if cfg.get("level") and units != PASCAL:
        raise ConfigError(f"{config_path}: tracker.level uses received levels in dB re 1 µPa, "
                          f"but {products_path} holds levels in {level_label(units)} (a "
                          "recording imported without --scale)")
    b = _read_bearings(prod, cfg.get("bearings"), products_path, cfg.get("cone_gate"),
                       cfg.get("level"))
    cfg_text = Path(config_path).read_text(encoding="utf-8", errors="replace")
    if b["time"].size == 0:
        warnings.warn(f"{products_path}: the bearings group has no rows (nothing was "
                      "detected): no track; an empty tracks table is written", stacklevel=2)
        with ProductsWriter(out_path, source=str(products_path), chain=cfg_text) as w:
            w.group("tracks", "tracks", stage="track", filter=cfg["filter"],
                    model=cfg["model"], lr=bool(cfg["lr"]), status=0)
        return
    src = cfg.get("nav") or as_text(prod["/"].get("source", ""))
    if not src:
        raise FormatError(f"{products_path}: no root attribute 'source' naming the recording; "
                          "set tracker.nav")
    rec = resolve_beside(src, config_path if cfg.get("nav") else products_path)
    t = b["time"]
    own, hd = ownship_states(_read_nav(rec), t)
    port = np.deg2rad(b["bearing_port_deg"])
    stbd = np.deg2rad(b["bearing_stbd_deg"])
    side = b.get("side")
    if side is not None and np.all(np.abs(side) == 1.0):
        zs = stbd[:, None]  # resolved by port/starboard beams: the one true bearing per row
    elif cfg["lr"]:
        zs = assign_by_continuity(port, stbd)
    else:
        zs = (port if cfg["side"] == "port" else stbd)[:, None]
    zs = wrap_pi(zs)
    if progress:
        _log.info(f"tracking {t.size} bearings with {cfg['filter'].upper()}"
                  f"{' + L-R resolution' if cfg['lr'] else ''}")
    xs, Ps, ws, status = track_bearings(t, zs, own, cfg,
                                        b[cfg["level"]] if "level" in cfg else None, hd)
    n_ok = t.size
    if status & 4:
        last = np.flatnonzero(np.any(ws > 0, axis=1))
        n_ok = int(last.max()) + 1 if last.size else 1
        warnings.warn(f"{out_path}: the track diverged after {n_ok} of {t.size} bearings; "
                      "only the rows before are written", stacklevel=2)
    with ProductsWriter(out_path, source=str(products_path), chain=cfg_text,
                        attrs={"recording": str(rec)}) as w:
        g = w.group("tracks", "tracks", stage="track", filter=cfg["filter"],
                    model=cfg["model"], lr=bool(cfg["lr"]), status=int(status))
        sl = slice(0, n_ok)
        g.append(time=t[sl], track_id=np.zeros(n_ok, dtype=np.int64),
                 x=xs[sl, 0] + own[sl, 0], y=xs[sl, 1] + own[sl, 1],
                 vx=xs[sl, 2] + own[sl, 2], vy=xs[sl, 3] + own[sl, 3],
                 cov=Ps[sl, :4, :4], own_x=own[sl, 0], own_y=own[sl, 1])


__all__ = ["run_single", "load_single_config", "check_single_config", "track_bearings",
           "build_components", "ownship_states", "assign_by_continuity"]
