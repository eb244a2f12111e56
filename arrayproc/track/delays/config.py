"""The ``[tracker]`` keys of the recursive TDOA tracker (``measurements = "delays"``), checked
on the parsed mapping (the file is read once, by the caller)."""

from __future__ import annotations

import math
from typing import Any

from arrayproc.config import Param, Schema, positive, read_toml
from arrayproc.errors import ConfigError
from arrayproc.track.filters import make_filter
from arrayproc.track.types import legacy_table

__all__ = ["DELAYS_PARAMS", "DELAYS_DEFAULTS", "GAUSSIAN_FILTERS", "is_delays_config",
           "load_delays_config", "check_delays_config"]

#: filters the delays tracker accepts (the SRF is bearings-only, the RPF not Gaussian)
GAUSSIAN_FILTERS = ("ekf", "ukf", "ckf", "ghf")



def _nonneg(v: Any) -> str | None:
    return None if v >= 0 else f"must be a number >= 0, got {v}"


def _range_bank(v: Any) -> str | None:
    ok = (isinstance(v, list) and len(v) == 3
          and all(isinstance(a, (int, float)) and not isinstance(a, bool) and math.isfinite(a)
                  for a in v)
          and 0 < v[0] < v[1] and isinstance(v[2], int) and v[2] >= 2)
    return None if ok else ("must be [r_min, r_max, n] with 0 < r_min < r_max (m) and an "
                            "integer n >= 2")


def _m_of_n(v: Any) -> str | None:
    ok = (isinstance(v, list) and len(v) == 2 and all(isinstance(a, int)
                                                      and not isinstance(a, bool) for a in v)
          and 1 <= v[0] <= v[1])
    return None if ok else "must be [m, n], integers with 1 <= m <= n"


#: the ``[tracker.delays]`` keys
DELAYS_PARAMS = Schema({
    "motion": Param("str", "static", "static (thesis eq. 3.40, Φ = I) or cv",
                    choices=("static", "cv")),
    "q": Param("float", 0.0, "process noise: static, m²/s position random walk; cv, m²/s³",
               check=_nonneg),
    "range_m": Param("float", 5000.0, "initial range prior along the first row's plane-wave "
                     "bearing", check=positive, unit="m"),
    "sigma_range_m": Param("float", 3000.0, "σ of the range prior", check=positive, unit="m"),
    "sigma_bearing_deg": Param("float", 0.5, "lower bound of the initial bearing σ",
                               check=positive, unit="deg"),
    "sigma_speed_mps": Param("float", 3.0, "cv: initial velocity σ per axis", check=positive,
                             unit="m/s"),
    "side": Param("str", "auto", "auto (mirror hypotheses), port or starboard",
                  choices=("auto", "port", "starboard")),
    "sigma_delay_s": Param("float", 0.0, "> 0: this σ for every delay; 0: the product's sigma "
                           "column", check=_nonneg, unit="s"),
    "min_corr": Param("float", 0.0, "leave out delays with a lower peak correlation",
                      check=lambda v: _nonneg(v) or (None if v <= 1 else "must be <= 1")),
    "source_dz_m": Param("float", 0.0, "source depth below the reference hydrophone",
                         unit="m"),
    "gate_prob": Param("float", 0.0, "> 0: χ² gate on the innovations (0: no gate)",
                       check=lambda v: _nonneg(v) or (None if v < 1 else
                                                      "must be < 1 (0: no gate)")),
    "group": Param("str", "", "delays group (default: the only one)"),
    "range_bank": Param("any", None, "optional [r_min, r_max, n]: n range priors from r_min to "
                        "r_max instead of range_m", check=_range_bank),
    "confirm": Param("any", [1, 1], "[m, n]: a track of several sources is confirmed with m "
                     "rows in its first n scans ([1, 1]: at birth)", check=_m_of_n),
    "max_misses": Param("int", 0, "a confirmed track is deleted after this many scans without "
                        "a row (0: never)", check=_nonneg),
    "array_motion": Param("bool", True, "delays brought back to a static array's (the array "
                          "moves while the wavefront crosses it)"),
}, "the recursive TDOA tracker ([tracker.delays] table)")
DELAYS_DEFAULTS: dict[str, Any] = {k: p.default for k, p in DELAYS_PARAMS.items()}
_TOP_KEYS = {"mode", "measurements", "filter", "nav", "params", "delays"}


def is_delays_config(tracker: Any) -> bool:
    """True when a parsed ``[tracker]`` table reads ``mode = "multi"`` and
    ``measurements = "delays"`` (errors are left to the full validation)."""
    tracker = legacy_table(tracker)
    return isinstance(tracker, dict) and tracker.get("mode") == "multi" \
        and tracker.get("measurements") == "delays"


def load_delays_config(path: str) -> dict[str, Any]:
    """Read (once) and check a delays tracker TOML: :func:`check_delays_config` of its
    ``[tracker]`` table."""
    doc, _ = read_toml(path, "tracker")
    return check_delays_config(doc.get("tracker"), path)


def check_delays_config(t: Any, path: str) -> dict[str, Any]:
    """Check the ``[tracker]`` mapping of a delays tracker (module doc of
    :mod:`arrayproc.track.delays`); ConfigError naming the file and key.

    Parameters
    ----------
    t : dict
        The parsed ``[tracker]`` table.
    path : str
        The file it came from (for messages).

    Returns
    -------
    dict
        ``filter``, ``params`` (the filter's), ``nav`` (or None), ``mode`` = "multi",
        ``multi`` = {"measurements": "delays"} and ``delays`` (every key of
        :data:`DELAYS_DEFAULTS`, checked).
    """
    t = legacy_table(t, path)
    if not isinstance(t, dict):
        raise ConfigError(f"{path}: missing [tracker] table")
    for k in t:
        if k not in _TOP_KEYS:
            raise ConfigError(f"{path}: unknown key tracker.{k} (a delays tracker takes "
                              f"{', '.join(sorted(_TOP_KEYS))})")
    filt = t.get("filter", "ukf")
    if filt not in GAUSSIAN_FILTERS:
        raise ConfigError(f"{path}: tracker.filter must be one of {', '.join(GAUSSIAN_FILTERS)} "
                          f"for delays, not {filt!r}")
    params = t.get("params", {})
    if not isinstance(params, dict):
        raise ConfigError(f"{path}: tracker.params must be a table")
    nav = t.get("nav")
    if nav is not None and not isinstance(nav, str):
        raise ConfigError(f"{path}: tracker.nav must be a string")
    given = t.get("delays", {})
    if not isinstance(given, dict):
        raise ConfigError(f"{path}: tracker.delays must be a table")
    d = DELAYS_PARAMS.check(given, path, prefix="tracker.delays.")
    if d["range_bank"] is not None:
        v = d["range_bank"]
        d["range_bank"] = [float(v[0]), float(v[1]), int(v[2])]
    try:
        make_filter(filt, **params)
    except ConfigError as e:
        raise ConfigError(f"{path}: tracker.params: {e}") from None
    return {"filter": filt, "params": dict(params), "nav": nav, "mode": "multi",
            "multi": {"measurements": "delays"}, "delays": d}

