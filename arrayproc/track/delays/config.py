"""The ``[tracker]`` keys of the recursive TDOA tracker (``measurements = "delays"``), checked
on the parsed mapping (the file is read once, by the caller)."""

from __future__ import annotations

import math
from typing import Any

from arrayproc.config import read_toml
from arrayproc.errors import ConfigError
from arrayproc.track.filters import make_filter

__all__ = ["DELAYS_DEFAULTS", "GAUSSIAN_FILTERS", "is_delays_config", "load_delays_config",
           "check_delays_config"]

#: filters the delays tracker accepts (the SRF is bearings-only, the RPF not Gaussian)
GAUSSIAN_FILTERS = ("ekf", "ukf", "ckf", "ghf")

DELAYS_DEFAULTS: dict[str, Any] = {
    "motion": "static", "q": 0.0, "range_m": 5000.0, "sigma_range_m": 3000.0,
    "sigma_bearing_deg": 0.5, "sigma_speed_mps": 3.0, "side": "auto", "sigma_delay_s": 0.0,
    "min_corr": 0.0, "source_dz_m": 0.0, "gate_prob": 0.0, "group": "", "range_bank": None,
    "array_motion": True,
}
_TOP_KEYS = {"mode", "measurements", "filter", "nav", "params", "delays"}


def is_delays_config(tracker: Any) -> bool:
    """True when a parsed ``[tracker]`` table reads ``mode = "multi"`` and
    ``measurements = "delays"`` (errors are left to the full validation)."""
    return isinstance(tracker, dict) and tracker.get("mode") == "multi" \
        and tracker.get("measurements") == "delays"


def _number(path: str, key: str, v: Any, positive: bool = False) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) \
            or v < 0 or (positive and v == 0):
        raise ConfigError(f"{path}: tracker.delays.{key} must be a number "
                          f"{'>' if positive else '>='} 0")
    return float(v)


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
    d = dict(DELAYS_DEFAULTS)
    for k, v in given.items():
        if k not in DELAYS_DEFAULTS:
            raise ConfigError(f"{path}: unknown key tracker.delays.{k}")
        if k in ("motion", "side", "group"):
            choices = {"motion": ("static", "cv"), "side": ("auto", "port", "starboard")}
            if not isinstance(v, str) or (k in choices and v not in choices[k]):
                raise ConfigError(f"{path}: tracker.delays.{k} must be "
                                  f"{' | '.join(choices.get(k, ('a group name',)))}, not {v!r}")
            d[k] = v
        elif k == "array_motion":
            if not isinstance(v, bool):
                raise ConfigError(f"{path}: tracker.delays.array_motion must be true or false")
            d[k] = v
        elif k == "range_bank":
            if (not isinstance(v, list) or len(v) != 3
                    or not all(isinstance(a, (int, float)) and not isinstance(a, bool)
                               and math.isfinite(a) for a in v)
                    or not 0 < v[0] < v[1] or not isinstance(v[2], int) or v[2] < 2):
                raise ConfigError(f"{path}: tracker.delays.range_bank must be [r_min, r_max, n]"
                                  " with 0 < r_min < r_max (m) and an integer n >= 2")
            d[k] = [float(v[0]), float(v[1]), int(v[2])]
        elif k == "source_dz_m":
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ConfigError(f"{path}: tracker.delays.source_dz_m must be a number")
            d[k] = float(v)
        else:
            d[k] = _number(path, k, v, positive=k in ("range_m", "sigma_range_m",
                                                      "sigma_bearing_deg", "sigma_speed_mps"))
    if d["gate_prob"] >= 1:
        raise ConfigError(f"{path}: tracker.delays.gate_prob must be < 1 (0: no gate)")
    if d["min_corr"] > 1:
        raise ConfigError(f"{path}: tracker.delays.min_corr must be <= 1")
    try:
        make_filter(filt, **params)
    except ConfigError as e:
        raise ConfigError(f"{path}: tracker.params: {e}") from None
    return {"filter": filt, "params": dict(params), "nav": nav, "mode": "multi",
            "multi": {"measurements": "delays"}, "delays": d}

