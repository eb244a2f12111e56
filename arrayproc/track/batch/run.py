"""``arrayproc tma``: batch maximum-likelihood TMA over the measurements of a products file.

Reads a ``bearings`` or ``delays`` group of a products file (docs/formats.md) and the array's
navigation and geometry from the recording (``/nav``, ``/array``; by default the recording the
products file names as its ``source``), solves one batch per window, and writes a products
file with one ``tma`` group (one row per solution: ``t0``, ``t1``, ``method``, ``x``, ``y``,
``vx``, ``vy``, ``cov``, ``crlb``, ``cost``, ``fim_cond``, ``heading_deg``, ``speed_mps``,
``range_sigma_m``, ``cost_mirror``).

Methods: ``bearings`` (thesis eqs. (3.41)-(3.47), :mod:`.bo_tma`), ``delays`` (eqs.
(3.48)-(3.52), :mod:`.td_tma`), ``compact`` (compact-array paper eqs. (1)-(5),
:mod:`.compact`); ``cross_fix`` reads several products files, one per static array
(:mod:`.cross_fix_run`). TMA TOML::

    [tma]
    method = "bearings"        # bearings | delays | compact | cross_fix
    window = 600.0             # s, one solution per window; 0 (default): the whole file
    step = 300.0               # s between window starts (default: window)
    sigma_bearing_deg = 0.5    # bearings/compact; absent: estimated from the residuals
    sigma_delay_s = 1e-4       # delays; absent: the product's sigma column, else estimated
    group = "bearings"         # products group (default: the only group of the method's kind)
    recording = "rec.h5"       # default: the products file's source
    side = "auto"              # bearings on a line array: auto or cone (the side may change
                               # from row to row: cone-angle residuals), port | starboard (one
                               # side for the window); delays: auto | port | starboard;
                               # compact: which bearing column (port | starboard) if they differ;
                               # a group with azimuth_deg (cbf_azel) is read as azimuths
    mirror_chi2 = 9.0          # bearings: the mirror solution is written too (preferred = 0)
                               # while it costs less than this (χ²) more than the preferred
    cone_gate = [20.0, 160.0]  # bearings/compact: only rows with cone angles in [lo, hi] deg
    min_range_m = 50.0         # global search interval (bearings/delays)
    max_range_m = 20000.0      # also the half-width of the compact grid
    seed = 0                   # differential evolution
    outliers = true            # bearings: polynomial-residue outlier rejection
    poly_degree = 5
    outlier_k = 4.0
    speed_mps = 7.3            # compact: assumed speed (required)
    sigma_speed_mps = 1.0      # compact: speed prior σ in the bound (default 0: known)
    correlation_s = 0.0        # compact: exponential correlation time of the bearing errors
    estimate_correlation = false  # compact, bearings_frequency: τ from a first fit's
                               # residuals, refit (arrayproc.track.batch.correlation);
                               # columns tau_s, tau_sigma_s
    n_grid = 200               # compact: grid nodes per axis
    n_headings = 72            # compact: headings over 360°
    array_motion = true        # bearings/delays: correct for the array's motion (below)
    retarded_time = true       # bearings/delays: the source at its emission time (below)
    source_depth_m = 10.0      # delays: ranges in 3-D with this source depth (default: planar)
    delay_correlation = 0.35   # delays: within-snapshot correlation (default: estimated)

The observer of a bearing is the array's phase centre (mean element position) at its time;
the delays use every element's world position in each snapshot's pose (``Recording.poses``).

``array_motion`` (default true): the array moves while a wavefront crosses it, so a moving
line array measures the apparent cone angle ``cos θ_app = cos θ / (1 + (v/c) cos θ)`` and every
delay is the static one scaled by ``1/(1 + V·u/c)`` (:mod:`.motion`, eqs. (M1)-(M4); ``V`` the
array's velocity, ``v`` its component along the array's heading, ``u`` the unit direction to
the source, ``c`` the recording's sound speed). The measurements are corrected back to the
static ones the models (3.44), (3.51) describe, ``cos θ = cos θ_app / (1 − (v/c) cos θ_app)``
and ``τ = τ_app (1 + V·u/c)``, with ``V`` from ``/nav`` at each measurement time (the
velocity of the track segment). Uncorrected, 3 m/s in 1500 m/s biases a cone angle of 60° by
+0.034° (towards broadside), which moves a batch solution by several CRLB σ. ``compact``
assumes a static array and is not corrected.

``retarded_time`` (default true): what arrives at time ``t_b`` left the source at
``t_b − R_b/c``; the models place the source at that emission point,
``p_e = p0 + v (τ_b − R_b/c)``, ``R_b`` its distance to the receiver (eq. (M5) of
:mod:`.motion`), so the state is the source's true position and velocity at the window start.
The thesis's model (false) describes the source ``R/c`` earlier, a track that is not quite
straight when the range changes, which biases the solution by several CRLB σ at the precision
of 32 or more hydrophones' delays.

``source_depth_m`` (delays): the element depths come from the poses (``/nav`` depth plus the
array geometry), so a known source depth turns the ranges of eq. (3.51) into 3-D ranges
``√(d_h² + Δz²)``; without it the model is planar (Δz = 0). The bearings method is planar
(its cone angles are slightly narrower than the horizontal ones when Δz ≠ 0).

``delay_correlation`` (delays): the delays of one snapshot share the reference hydrophone's
noise, so they are correlated (ρ = ½ for equal noise); the likelihood and the FIM use the
compound-symmetric covariance of eq. (D1) (:mod:`.td_tma`). Absent: ρ estimated from the
residuals of an independent-error fit; 0: the thesis's independent errors. The ρ used is
stored in the group attribute ``delay_correlation`` (one value per window).
"""

from __future__ import annotations

import logging
import math
import os
import warnings
from collections.abc import Mapping
from typing import Any

import numpy as np

from arrayproc.config import Param, Schema, positive, read_toml, resolve_beside
from arrayproc.errors import ConfigError, FormatError
from arrayproc.io.products import ProductsWriter, delays_columns, read_products
from arrayproc.io.recording import Recording
from arrayproc.io.schema import groups_of_kind
from arrayproc.io.text import as_text

from .bf_tma import solve_bearings_frequency
from .bo_tma import solve_line_bearings
from .compact import solve_compact
from .correlation import solve_compact_estimated
from .motion import axial_speed, nav_velocity, static_cone
from .result import TmaSolution
from .td_tma import solve_delays

_log = logging.getLogger(__name__)

__all__ = ["PARAMS", "load_tma_config", "run_tma", "read_measurements", "solve_window",
           "true_bearings"]


def _non_negative(v: Any) -> str | None:
    return None if v >= 0 else f"must be >= 0, got {v}"


def _unit_interval(v: Any) -> str | None:
    return None if 0 <= v < 1 else f"must be in [0, 1), got {v}"


def _gate(v: Any) -> str | None:
    return None if len(v) == 2 and 0 <= v[0] < v[1] <= 180 else \
        "must be [lo, hi] cone angles, deg, 0 <= lo < hi <= 180"


PARAMS = Schema({
    "method": Param("str", doc="bearings | bearings_frequency | delays | compact | "
                    "cross_fix | auto (a tracks file: bearings_frequency for a track with line "
                    "frequencies, else bearings; a products file: bearings); cross_fix: the "
                    "bearings of two or more static arrays' products files",
                    choices=("bearings", "bearings_frequency", "delays", "compact",
                             "cross_fix", "auto")),
    "window": Param("float", 0.0, "s per solution; 0: the whole file", check=_non_negative),
    "step": Param("float", 0.0, "s between window starts; 0: the window", check=_non_negative),
    "sigma_bearing_deg": Param("float", 0.0, "bearing σ, deg; 0: estimated", check=_non_negative),
    "sigma_freq_hz": Param("float", 0.0, "bearings_frequency: line-frequency σ, Hz; 0: "
                           "estimated from the residuals", check=_non_negative, unit="Hz"),
    "min_rows": Param("int", 10, "tracks file: a confirmed track with fewer measurement rows "
                      "is not solved", check=positive),
    "min_duration_s": Param("float", 60.0, "tracks file: a confirmed track whose rows span "
                            "less than this is not solved", check=_non_negative, unit="s"),
    "sigma_delay_s": Param("float", 0.0, "delay σ, s; 0: product σ or estimated",
                           check=_non_negative),
    "group": Param("str", "", "products group to read"),
    "recording": Param("str", "", "recording with /nav and /array"),
    "side": Param("str", "auto", "line arrays: cone or auto (the side may change from row to "
                  "row), port or starboard (one side for the window)",
                  choices=("auto", "cone", "port", "starboard")),
    "mirror_chi2": Param("float", 9.0, "the mirror solution is written too while its cost "
                         "exceeds the preferred one's by less than this (χ² units)",
                         check=positive),
    "cone_gate": Param("band", None, "cone-angle gate, deg", check=_gate),
    "min_range_m": Param("float", 50.0, "m", check=positive),
    "max_range_m": Param("float", 20000.0, "m", check=positive),
    "seed": Param("int", 0, "differential-evolution seed"),
    "outliers": Param("bool", True, "polynomial-residue outlier rejection"),
    "poly_degree": Param("int", 5, "outlier polynomial degree", check=_non_negative),
    "outlier_k": Param("float", 4.0, "outlier threshold, σ", check=positive),
    "speed_mps": Param("float", None, "compact: assumed speed, m/s", check=positive),
    "sigma_speed_mps": Param("float", 0.0, "compact: speed prior σ, m/s", check=_non_negative),
    "correlation_s": Param("float", 0.0, "compact: correlation time, s (with "
                           "estimate_correlation: that of the first fit)", check=_non_negative),
    "estimate_correlation": Param("bool", False, "compact and bearings_frequency: estimate "
                                  "the errors' correlation time from the residuals of a first "
                                  "fit and refit with it (bearings_frequency: per kind, "
                                  "exponential plus white errors, generalised least squares)"),
    "n_grid": Param("int", 200, "compact: grid nodes per axis", check=positive),
    "n_headings": Param("int", 72, "compact: headings", check=positive),
    "pair_cost": Param("float", 3.0, "cross_fix of two tracks files: the largest cost per "
                       "degree of freedom of two tracks' joint fit for them to be paired as "
                       "one target", check=positive),
    "popsize": Param("int", 20, "differential-evolution population factor", check=positive),
    "maxiter": Param("int", 400, "differential-evolution generations", check=positive),
    "array_motion": Param("bool", True, "bearings/delays: correct for the array's motion "
                          "during the wavefront's passage"),
    "retarded_time": Param("bool", True, "bearings/delays: model the source at its emission "
                           "time"),
    "source_depth_m": Param("float", None, "delays: source depth (m) for 3-D ranges; absent: "
                            "planar model", check=_non_negative),
    "delay_correlation": Param("float", None, "delays: within-snapshot correlation in [0, 1); "
                               "absent: estimated", check=_unit_interval),
}, "a TMA solution ([tma] table)")


def load_tma_config(path: str) -> dict[str, Any]:
    """Read and check a TMA TOML (``[tma]`` table); ConfigError naming the file and key.

    Parameters
    ----------
    path : str
        TOML file.

    Returns
    -------
    dict
        Every key of :data:`PARAMS`, defaults filled in.
    """
    doc, _ = read_toml(path, "TMA")
    return tma_config(doc, path)


def tma_config(doc: Mapping[str, Any], path: str) -> dict[str, Any]:
    """Check a parsed TMA document (its ``[tma]`` table) against :data:`PARAMS`.

    Parameters
    ----------
    doc : mapping
        The parsed TOML.
    path : str
        Its file, for the messages.

    Returns
    -------
    dict
        Every key of :data:`PARAMS`, defaults filled in.
    """
    if not isinstance(doc.get("tma"), Mapping):
        raise ConfigError(f"{path}: missing [tma] table")
    cfg = PARAMS.check(doc["tma"], path, prefix="tma.")
    if cfg["method"] == "compact" and cfg["speed_mps"] is None:
        raise ConfigError(f"{path}: tma.speed_mps is required for method = 'compact'")
    if cfg["min_range_m"] >= cfg["max_range_m"]:
        raise ConfigError(f"{path}: tma.min_range_m must be below tma.max_range_m")
    return cfg


def _group(prod: dict, kind: str, name: str, path: str) -> tuple[str, dict]:
    if name:
        if name not in prod or name == "/":
            raise FormatError(f"{path}: no group {name!r} (tma.group)")
        if as_text(prod[name].get("kind")) != kind:
            raise FormatError(f"{path}: group {name!r} is of kind "
                              f"{as_text(prod[name].get('kind'))!r}, not {kind!r}")
        return name, prod[name]
    names = groups_of_kind(prod, kind)
    if not names:
        raise FormatError(f"{path}: no {kind} group")
    if len(names) > 1:
        raise ConfigError(f"{path}: several {kind} groups ({', '.join(names)}); choose one "
                          "with tma.group")
    return names[0], prod[names[0]]


def read_measurements(products_path: str, cfg: dict[str, Any]) -> dict[str, Any]:
    """The measurements a method needs from a products file.

    Bearings (one row per time, the strongest by ``snr_db``): ``time`` (s), ``cone`` and
    ``heading`` (rad; heading = the port/starboard pair's mean, cone = half their
    difference), ``port``, ``stbd`` (rad), and ``azimuth`` (rad) when the group has
    ``azimuth_deg`` (a volumetric/planar array's rows, which ``compact`` then reads; port and
    starboard default to it when absent), else None; ``freq`` (Hz) for ``bearings_frequency``,
    which reads a ``lines`` group (one tonal's rows: :func:`select_rows`), else None. Delays:
    ``time``, ``tau`` (n, n_ch) s, ``sigma`` (n, n_ch) s or None, ``reference``.

    Parameters
    ----------
    products_path : str
        Products file.
    cfg : dict
        Checked TMA configuration.

    Returns
    -------
    dict
        Also ``group`` (the name read) and ``source`` (the products' source attribute).
    """
    prod = read_products(products_path)
    src = as_text(prod["/"].get("source", ""))
    kind = {"delays": "delays", "bearings_frequency": "lines"}.get(cfg["method"], "bearings")
    name, g = _group(prod, kind, cfg["group"], products_path)
    out: dict[str, Any] = {"group": name, "source": src}
    if kind == "delays":
        d = delays_columns(g, products_path)
        out.update(time=d["time"], tau=d["tau"], sigma=d["sigma"], reference=d["reference"])
        return out
    cols = bearing_columns(g, products_path, need_freq=kind == "lines")
    t = cols["time"]
    ok = np.isfinite(t) & np.isfinite(cols["port"]) & np.isfinite(cols["stbd"])
    if cols["azimuth"] is not None:
        ok &= np.isfinite(cols["azimuth"])
    if cols["freq"] is not None:
        ok &= np.isfinite(cols["freq"])
    if cfg["cone_gate"] is not None:
        if "cone_deg" not in g:
            raise FormatError(f"{products_path}: bearings column 'cone_deg' is missing "
                              "(needed by tma.cone_gate)")
        cone = np.asarray(g["cone_deg"], float).reshape(-1)
        ok &= (cone >= cfg["cone_gate"][0]) & (cone <= cfg["cone_gate"][1])
    score = np.asarray(g.get("snr_db", g.get("level_db", np.zeros(t.size))), float).reshape(-1)
    score = np.where(np.isfinite(score), score, -np.inf)
    idx = np.flatnonzero(ok)
    idx = idx[np.lexsort((-score[idx], t[idx]))]          # by time, strongest first
    first = np.ones(idx.size, bool)
    first[1:] = t[idx][1:] != t[idx][:-1]
    idx = idx[first]                                        # one row per time
    if idx.size < 5:
        raise FormatError(f"{products_path}: fewer than 5 usable bearing rows in {name!r}")
    out.update(select_rows(cols, idx))
    return out


def bearing_columns(g: Mapping[str, Any], path: str, need_freq: bool = False
                    ) -> dict[str, np.ndarray | None]:
    """The columns of a ``bearings`` (or ``lines``) group that the bearing methods read, in
    degrees as stored: ``time``, ``port``, ``stbd`` (port and starboard default to
    ``azimuth_deg`` when absent), ``azimuth`` (None without ``azimuth_deg``) and ``freq``
    (``freq_hz``, None when absent; FormatError when ``need_freq`` and absent)."""
    has_az = "azimuth_deg" in g  # a volumetric/planar array's bearings (cbf_azel)
    need = ("time",) + (() if has_az else ("bearing_port_deg", "bearing_stbd_deg"))
    for k in need + (("freq_hz",) if need_freq else ()):
        if k not in g:
            raise FormatError(f"{path}: {as_text(g.get('kind', 'bearings'))} column {k!r} is "
                              "missing")

    def col(k: str) -> np.ndarray | None:
        return np.asarray(g[k], float).reshape(-1) if k in g else None

    az = col("azimuth_deg")
    port, stbd = col("bearing_port_deg"), col("bearing_stbd_deg")
    return {"time": col("time"), "port": az if port is None else port,
            "stbd": az if stbd is None else stbd, "azimuth": az, "freq": col("freq_hz")}


def select_rows(cols: Mapping[str, np.ndarray | None], idx: np.ndarray) -> dict[str, Any]:
    """The rows ``idx`` of :func:`bearing_columns` as the bearing methods read them: ``time``
    (s), ``port``, ``stbd`` (rad), ``cone`` and ``heading`` (rad; heading = the port/starboard
    pair's mean, cone = half their difference), ``azimuth`` (rad or None) and ``freq`` (Hz or
    None)."""
    p, s = np.deg2rad(cols["port"][idx]), np.deg2rad(cols["stbd"][idx])
    cone = np.mod(s - p, 2 * np.pi) / 2                     # stbd − port = 2θ
    az, f = cols["azimuth"], cols["freq"]
    return {"time": cols["time"][idx], "port": p, "stbd": s, "cone": cone, "heading": p + cone,
            "azimuth": None if az is None else np.deg2rad(az[idx]),
            "freq": None if f is None else f[idx]}


def _windows(t: np.ndarray, window: float, step: float) -> list[tuple[float, float]]:
    if window <= 0:
        return [(float(t[0]), float(t[-1]))]
    step = step if step > 0 else window
    out = []
    start = float(t[0])
    while start < t[-1]:
        out.append((start, min(start + window, float(t[-1]))))
        if start + window >= t[-1]:
            break
        start += step
    return out


def solve_window(meas: dict, rec: Recording, cfg: dict, w0: float, w1: float) -> TmaSolution:
    """One batch TMA solution over the measurements with times in [w0, w1].

    Parameters
    ----------
    meas : dict
        Measurements as returned by :func:`read_measurements`.
    rec : Recording
        The recording whose navigation and geometry place the array.
    cfg : dict
        TMA configuration from :func:`load_tma_config`.
    w0, w1 : float
        Window start and end, s (the solution's state is at ``w0``).

    Returns
    -------
    TmaSolution
        The estimate, its CRLB and costs, as one row of the ``tma`` product.
    """
    t = meas["time"]
    sel = (t >= w0) & (t <= w1)
    ts = t[sel]
    common = dict(seed=cfg["seed"], t0=w0, t1=w1)
    if cfg["method"] == "delays":
        poses = rec.poses(ts)
        elem = np.stack([p.elements[:, :2] for p in poses])
        tau = meas["tau"][sel]
        if tau.shape[1] != elem.shape[1]:
            raise FormatError(f"delays have {tau.shape[1]} channels but the recording "
                              f"{rec.path} has {elem.shape[1]} active channels")
        if cfg["sigma_delay_s"] > 0:
            sig = cfg["sigma_delay_s"]
        elif meas["sigma"] is not None:
            s = meas["sigma"][sel]
            sig = np.where(np.isfinite(s) & (s > 0), s, np.inf)
        else:
            sig = None
        return solve_delays(ts, tau, elem, sig, ref=meas["reference"],
                            sound_speed=rec.sound_speed,
                            side="auto" if cfg["side"] == "cone" else cfg["side"],
                            heading_rad=np.deg2rad([p.heading for p in poses]),
                            array_velocity=(nav_velocity(rec.nav, ts) if cfg["array_motion"]
                                            else None),
                            retarded=cfg["retarded_time"],
                            correlation=cfg["delay_correlation"],
                            dz=(None if cfg["source_depth_m"] is None else
                                np.stack([p.elements[:, 2] for p in poses])
                                - cfg["source_depth_m"]),
                            min_range_m=cfg["min_range_m"], max_range_m=cfg["max_range_m"],
                            popsize=cfg["popsize"], maxiter=cfg["maxiter"], **common)
    poses = rec.poses(ts)
    obs = np.stack([p.elements[:, :2].mean(0) for p in poses])     # phase centre
    sig = np.deg2rad(cfg["sigma_bearing_deg"]) or None
    if cfg["method"] == "compact":
        y = true_bearings(meas, sel, cfg)
        kw = dict(speed_mps=cfg["speed_mps"], sigma_speed_mps=cfg["sigma_speed_mps"],
                  correlation_s=cfg["correlation_s"], t0=w0, t1=w1,
                  max_range_m=cfg["max_range_m"], n_grid=cfg["n_grid"],
                  n_headings=cfg["n_headings"])
        if cfg["estimate_correlation"]:
            return solve_compact_estimated(ts, y, obs.mean(0), sig, **kw)
        sol = solve_compact(ts, y, obs.mean(0), sig, **kw)
        sol.tau_s = cfg["correlation_s"]
        return sol
    if cfg["method"] == "bearings_frequency":
        return _solve_bf(meas, sel, ts, poses, obs, rec, cfg, w0, w1)
    kw = dict(min_range_m=cfg["min_range_m"], max_range_m=cfg["max_range_m"],
              outliers=cfg["outliers"], poly_degree=cfg["poly_degree"],
              outlier_k=cfg["outlier_k"], popsize=cfg["popsize"], maxiter=cfg["maxiter"],
              retarded_c=rec.sound_speed if cfg["retarded_time"] else None, **common)
    v_ax = None
    if cfg["array_motion"]:
        v_ax = axial_speed(nav_velocity(rec.nav, ts), np.deg2rad([p.heading for p in poses]))
    return solve_line_bearings(ts, meas["cone"][sel], meas["heading"][sel], obs, sig,
                               side=cfg["side"], axial_speed_mps=v_ax,
                               sound_speed=rec.sound_speed, **kw)


def true_bearings(meas: Mapping[str, Any], sel: np.ndarray, cfg: Mapping[str, Any]
                  ) -> np.ndarray:
    """The rows ``sel``'s true bearings (rad) for the methods that read one bearing per row
    (``compact``, ``cross_fix``): a volumetric/planar array's azimuths, else the port/starboard
    pair when they agree, else the side ``tma.side`` names (ConfigError when it names none)."""
    port, stbd = meas["port"][sel], meas["stbd"][sel]
    same = np.allclose(np.angle(np.exp(1j * (port - stbd))), 0.0, atol=1e-9)
    if meas.get("azimuth") is not None:  # azimuths of a volumetric array: unambiguous
        return meas["azimuth"][sel]
    if same or cfg["side"] == "starboard":
        return stbd
    if cfg["side"] == "port":
        return port
    raise ConfigError(f"tma.side must be 'port' or 'starboard' for method = '{cfg['method']}' "
                      "on a line array's bearings (their port and starboard differ)")


def _solve_bf(meas: dict, sel: np.ndarray, ts: np.ndarray, poses: list, obs: np.ndarray,
              rec: Recording, cfg: dict, w0: float, w1: float) -> TmaSolution:
    """Bearings + frequency over the window's rows (:func:`.bf_tma.solve_bearings_frequency`):
    a line array's cone angles (corrected for the array's motion when ``array_motion``) with
    no side chosen, or a volumetric array's azimuths."""
    if meas.get("freq") is None:
        raise ConfigError("tma.method = 'bearings_frequency' needs line frequencies (a lines "
                          "group, or a track with frequencies)")
    vel = nav_velocity(rec.nav, ts)
    hd = np.deg2rad([p.heading for p in poses])
    if meas.get("azimuth") is not None:
        ang, heading = meas["azimuth"][sel], None
    else:
        ang, heading = meas["cone"][sel], meas["heading"][sel]
        if cfg["array_motion"]:
            ang = static_cone(ang, axial_speed(vel, hd), rec.sound_speed)
    return solve_bearings_frequency(
        ts, ang, meas["freq"][sel], obs, vel, np.deg2rad(cfg["sigma_bearing_deg"]) or None,
        cfg["sigma_freq_hz"] or None, heading_rad=heading, sound_speed=rec.sound_speed,
        t0=w0, t1=w1, min_range_m=cfg["min_range_m"], max_range_m=cfg["max_range_m"],
        seed=cfg["seed"], popsize=cfg["popsize"], maxiter=cfg["maxiter"],
        outliers=cfg["outliers"], poly_degree=cfg["poly_degree"], outlier_k=cfg["outlier_k"],
        retarded=cfg["retarded_time"], correlated=cfg["estimate_correlation"])


def run_tma(products_path: str, config_path: str, output_path: str,
            progress: bool = False) -> list[TmaSolution]:
    """Solve batch TMA over a products file's measurements and write a ``tma`` group.

    Parameters
    ----------
    products_path : str
        Products file with a ``bearings`` or ``delays`` group.
    config_path : str
        TMA TOML (see the module docstring).
    output_path : str
        Products file to write (one ``tma`` group named ``tma``).
    progress : bool
        One line per solution on stderr.

    Returns
    -------
    list of TmaSolution
    """
    cfg = load_tma_config(config_path)
    if cfg["method"] == "cross_fix":
        raise ConfigError(f"{config_path}: tma.method = 'cross_fix' reads two or more products "
                          f"files, one per array; only {products_path} was given")
    if cfg["method"] == "auto":  # a products file's bearing rows carry no source's tonal
        cfg["method"] = "bearings"
    meas = read_measurements(products_path, cfg)
    rec_path = cfg["recording"] or meas["source"]
    if not rec_path:
        raise ConfigError(f"{config_path}: tma.recording is needed (the products file names "
                          "no source recording)")
    rec_path = resolve_beside(rec_path, products_path if not cfg["recording"] else config_path)
    sols = []
    with Recording(rec_path) as rec:
        for w0, w1 in _windows(meas["time"], cfg["window"], cfg["step"]):
            n = int(np.sum((meas["time"] >= w0) & (meas["time"] <= w1)))
            if n < 5:
                continue
            try:
                sol = solve_window(meas, rec, cfg, w0, w1)
            except ValueError as e:
                raise FormatError(f"{products_path}: window [{w0:g}, {w1:g}] s: {e}") from None
            sols.append(sol)
            warn_if_far(sol, rec, cfg, f"{products_path}: window [{w0:g}, {w1:g}] s")
            if progress:
                _log.info(f"tma {cfg['method']} [{w0:8.1f}, {w1:8.1f}] s: x "
                          f"{sol.state[0]:9.1f} y {sol.state[1]:9.1f} m, course "
                          f"{sol.heading_deg:5.1f} deg, speed {sol.speed_mps:5.2f} m/s, range σ "
                          f"{sol.range_sigma:8.1f} m")
    if not sols:
        raise FormatError(f"{products_path}: no window with 5 or more measurements")
    sols = with_unresolved_mirrors(sols, cfg["mirror_chi2"], products_path)
    write_tma(output_path, sols, rec_path, cfg, root_attrs={"products": os.path.abspath(
        products_path)}, measurements=meas["group"], products=os.path.abspath(products_path))
    return sols


def warn_if_far(sol: TmaSolution, rec: Recording, cfg: dict[str, Any], where: str) -> bool:
    """Warn (and return True) when a solution lies beyond twice ``tma.max_range_m`` from the
    array at its start: the rows may be unobservable (no ownship manoeuvre) or mix sources."""
    return warn_if_far_from(sol, rec.nav.at(sol.t0)[0][:1], cfg, where)


def warn_if_far_from(sol: TmaSolution, sites_xy: np.ndarray, cfg: dict[str, Any],
                     where: str) -> bool:
    """Warn (and return True) when a solution lies beyond twice ``tma.max_range_m`` from the
    nearest of the arrays at ``sites_xy`` ((n, 2) m) at its start (:func:`warn_if_far`)."""
    d = np.asarray(sites_xy, float).reshape(-1, 2) - np.asarray(sol.state[:2], float)
    rng = float(np.min(np.hypot(d[:, 0], d[:, 1])))
    if rng <= 2.0 * cfg["max_range_m"]:
        return False
    warnings.warn(f"{where}: the solution lies {rng:.3g} m away, beyond twice "
                  "tma.max_range_m: the rows may be unobservable (no ownship manoeuvre) or "
                  "mix several sources (give one source's rows, e.g. a cone_gate)",
                  stacklevel=4)
    return True


def tma_columns(sols: list[TmaSolution], track_ids: list[int] | None = None,
                pair_ids: list[int] | None = None) -> dict[str, np.ndarray]:
    """The ``tma`` rows of solutions (products kind ``tma``, docs/formats.md): the kinematic
    4 × 4 blocks of ``cov`` and ``crlb``; ``f0_hz`` and ``sigma_f0_hz`` (NaN without a rest
    frequency) and ``track_id`` when ``track_ids`` (one per solution) is given, and
    ``pair_track_id`` when ``pair_ids`` is. A solution is ``preferred`` unless it is another's
    mirror."""
    mirrors = {id(s.mirror) for s in sols if s.mirror is not None}
    f0 = np.array([s.state[4] if s.state.size > 4 else np.nan for s in sols])
    sf0 = np.array([np.sqrt(s.crlb[4, 4]) if s.state.size > 4 else np.nan for s in sols])
    cols = dict(
        t0=np.array([s.t0 for s in sols]), t1=np.array([s.t1 for s in sols]),
        method=np.array([s.method.encode() for s in sols], dtype="S20"),
        x=np.array([s.state[0] for s in sols]), y=np.array([s.state[1] for s in sols]),
        vx=np.array([s.state[2] for s in sols]), vy=np.array([s.state[3] for s in sols]),
        cov=np.stack([s.cov[:4, :4] for s in sols]), crlb=np.stack([s.crlb[:4, :4] for s in sols]),
        cost=np.array([s.cost for s in sols]),
        fim_cond=np.array([s.fim_cond if math.isfinite(s.fim_cond) else np.inf for s in sols]),
        heading_deg=np.array([s.heading_deg for s in sols]),
        speed_mps=np.array([s.speed_mps for s in sols]),
        range_sigma_m=np.array([s.range_sigma for s in sols]),
        cost_mirror=np.array([s.cost_other for s in sols]),
        preferred=np.array([id(s) not in mirrors for s in sols], dtype=np.int8))
    tau = np.array([s.tau_s for s in sols])
    if np.any(np.isfinite(tau)):  # compact solutions
        cols.update(tau_s=tau, tau_sigma_s=np.array([s.tau_sigma_s for s in sols]))
    if track_ids is not None:
        cols.update(track_id=np.asarray(track_ids, np.int64), f0_hz=f0, sigma_f0_hz=sf0,
                    n_used=np.array([s.n_used for s in sols], np.int64))
    elif np.any(np.isfinite(f0)):
        cols.update(f0_hz=f0, sigma_f0_hz=sf0)
    if pair_ids is not None:
        cols.update(pair_track_id=np.asarray(pair_ids, np.int64))
    return cols


def write_tma(output_path: str, sols: list[TmaSolution], rec_path: str, cfg: dict[str, Any],
              root_attrs: dict[str, Any], track_ids: list[int] | None = None,
              pair_ids: list[int] | None = None, **attrs: Any) -> None:
    """Write the solutions as one ``tma`` group named ``tma`` (:func:`tma_columns`); ``attrs``
    are the group's attributes beside the method's settings."""
    with ProductsWriter(output_path, source=rec_path, attrs=root_attrs) as w:
        g = w.group("tma", "tma", stage="tma", method=cfg["method"], recording=rec_path,
                    side=",".join(s.side for s in sols),
                    sigma_bearing_deg=cfg["sigma_bearing_deg"],
                    sigma_delay_s=cfg["sigma_delay_s"], sigma_freq_hz=cfg["sigma_freq_hz"],
                    delay_correlation=",".join(f"{s.correlation:.3f}" for s in sols),
                    array_motion=int(cfg["array_motion"]),
                    retarded_time=int(cfg["retarded_time"]), **attrs)
        g.append(**tma_columns(sols, track_ids, pair_ids))


def with_unresolved_mirrors(sols: list[TmaSolution], chi2: float, where: str
                            ) -> list[TmaSolution]:
    """The solutions, each followed by its mirror (sides flipped) while the data prefer it by
    less than ``chi2`` (the cost difference in χ² units), with one warning per such window."""
    out = []
    for s in sols:
        out.append(s)
        m = s.mirror
        if m is not None and m.cost - s.cost < chi2:
            warnings.warn(f"{where}: window [{s.t0:g}, {s.t1:g}] s: the mirror solution "
                          f"({m.side}) fits within Δχ² = {m.cost - s.cost:.2g} of the preferred "
                          f"one ({s.side}): the manoeuvre has not resolved the side; both are "
                          "written (column preferred)", stacklevel=2)
            out.append(m)
    return out
