"""The ``[tracker]`` keys of the multi-target tracker (``type = "multi"``), checked on the
parsed mapping (the file is read once, by the caller): the manager's keys, the measurement
kinds' sub-tables (declared with :class:`arrayproc.config.Param`) and, through
:func:`arrayproc.track.single.check_single_config`, the TMA filter's keys."""

from __future__ import annotations

from typing import Any

from arrayproc.config import Param, Schema, positive, read_toml
from arrayproc.errors import ConfigError
from arrayproc.track.manage.initiate import MofN
from arrayproc.track.types import legacy_table

__all__ = ["MULTI_KEYS", "SUB_PARAMS", "tracker_mode", "split_config", "check_multi_config"]

MULTI_KEYS = {"mode", "measurements", "association", "gate_prob", "confirm", "max_misses",
              "hit_window",
              "pd", "clutter_density", "bearing", "contacts", "positions", "lines", "fused"}


def _f(default: float, doc: str) -> Param:
    return Param("float", default, doc, check=positive)


#: the sub-tables' keys (each number > 0)
SUB_PARAMS: dict[str, dict[str, Param]] = {
    "bearing": {
        "space": Param("str", "bearing", "bearing (mirrored hypotheses) | cone",
                       choices=("bearing", "cone")),
        "sigma_cone_deg": _f(0.7, "cone-angle σ at broadside, deg"),
        "q_cone": _f(0.05, "cone-acceleration noise (space = cone), deg²/s³"),
        "q_bearing": _f(0.002, "bearing-acceleration noise (space = bearing), deg²/s³"),
        "turn_ref_deg_s": _f(0.1, "Q × (1 + (heading rate / turn_ref)²), deg/s"),
        "merge_deg": _f(4.0, "rows of a scan closer than this form one measurement, deg"),
        "sigma_rate_deg_s": _f(0.5, "initial cone-rate σ, deg/s"),
        "merge_d2": _f(4.0, "d² under which two confirmed tracks are duplicates"),
        "min_sigma_sin": _f(0.2, "floor of sin θ in the noise widening"),
    },
    "contacts": {
        "sigma_bearing_deg": _f(2.0, "bearing σ, deg"),
        "sigma_range_m": _f(20.0, "range σ, m"),
        "sigma_range_rate_mps": _f(0.3, "range-rate σ, m/s"),
        "q": _f(0.01, "acceleration noise, m²/s³"),
        "sigma_speed_mps": _f(5.0, "unobserved tangential speed at initiation, m/s"),
        "mirror": Param("bool", True, "enter both candidate bearings of a line array"),
        "moving_only": Param("bool", False, "only contacts flagged moving enter"),
        "min_snr_db": Param("float", 0.0, "only contacts with snr_db at least this (> 0) enter",
                            check=positive),
    },
    "lines": {
        "sigma_hz": Param("float", 0.15, "σ of a line contact's frequency", check=positive,
                          unit="Hz"),
        "q_freq": Param("float", 1e-4, "frequency-acceleration noise of a tonal (times the "
                        "turn factor of tracker.bearing.turn_ref_deg_s)", check=positive,
                        unit="Hz²/s³"),
        "sigma_rate_hz_s": Param("float", 0.02, "initial σ of a tonal's frequency rate",
                                 check=positive, unit="Hz/s"),
        "sigma_line_deg_hz": Param("float", 1250.0, "a line's cone-angle σ at broadside is "
                                   "this / (f √(S/N)) (beam width ∝ wavelength, precision ∝ "
                                   "1/√SNR)", check=positive, unit="deg·Hz"),
        "min_sigma_line_deg": Param("float", 0.2, "floor of a line's cone-angle σ at broadside",
                                    check=positive, unit="deg"),
        "max_tonals": Param("int", 4, "tonal slots per track",
                            check=lambda v: None if v >= 1 else "must be an integer >= 1"),
        "max_age_s": Param("float", 60.0, "a tonal not updated for this long leaves its track",
                           check=positive, unit="s"),
        "adopt_d2": Param("float", 1.0, "bearing d² under which an unassigned line joins the "
                          "only track near it as a new tonal", check=positive),
        "min_snr_db": Param("float", 0.0, "only lines with snr_db at least this (> 0) enter",
                            check=positive, unit="dB"),
        "same_source_deg": Param("float", 1.0, "confirmed tracks with disjoint tonals whose "
                                 "mirror bearings stay this close for same_source_scans "
                                 "scans are one source and merge", check=positive,
                                 unit="deg"),
        "reid_s": Param("float", 120.0, "a confirmed track that starts within this of the "
                        "last measurement of a deleted one, with a tonal within reid_hz and a "
                        "mirror bearing within reid_deg of its there, continues it (the "
                        "deleted one's later coasted points dropped)", check=positive,
                        unit="s"),
        "reid_hz": Param("float", 1.0, "see reid_s", check=positive, unit="Hz"),
        "reid_deg": Param("float", 20.0, "see reid_s", check=positive, unit="deg"),
        "same_source_scans": Param("int", 10, "see same_source_deg",
                                   check=lambda v: None if v >= 1
                                   else "must be an integer >= 1"),
    },
    "positions": {
        "q": _f(0.01, "acceleration noise, m²/s³"),
        "sigma_speed_mps": _f(5.0, "initial speed σ per axis, m/s"),
    },
    "fused": {
        "sigma_bearing_deg": Param("float", 1.0, "azimuth σ of every array's rows",
                                   check=positive, unit="deg"),
        "q": Param("float", 0.01, "acceleration noise of the Cartesian CV state",
                   check=positive, unit="m²/s³"),
        "sigma_speed_mps": Param("float", 5.0, "initial speed σ per axis", check=positive,
                                 unit="m/s"),
        "pair_s": Param("float", 4.0, "largest time between the two bearings of an "
                        "initiating cross-fix", check=positive, unit="s"),
        "min_cross_deg": Param("float", 10.0, "rays crossing at less than this (or more than "
                               "180° − this) start no track", check=positive, unit="deg"),
        "max_range_m": Param("float", 10000.0, "cross-fixes farther than this from either "
                             "array start no track", check=positive, unit="m"),
        "merge_deg": Param("float", 4.0, "rows of a scan closer than this (azimuth) are one "
                           "measurement", check=positive, unit="deg"),
        "merge_d2": Param("float", 4.0, "d² (positions) under which two confirmed tracks "
                          "are duplicates", check=positive),
        "persist": Param("int", 4, "a free bearing with this many free bearings of its array "
                         "within merge_deg over the last 4 pair_s (itself included) may also "
                         "pair with a bearing a track took (0: never)",
                         check=lambda v: None if v >= 0 else "must be an integer >= 0"),
    },
}


def tracker_mode(tracker: Any) -> str:
    """``mode`` of a parsed ``[tracker]`` table ("single" when absent), written either way
    (:mod:`arrayproc.track.types`)."""
    t = legacy_table(tracker)
    return str(t.get("mode", "single")) if isinstance(t, dict) else "single"



def split_config(path: str) -> tuple[dict[str, Any], dict[str, Any]]:
    """Read (once) a multi-mode tracker TOML: :func:`check_multi_config` of its ``[tracker]``
    table."""
    doc, _ = read_toml(path, "tracker")
    return check_multi_config(doc.get("tracker"), path)


def _int_pair(what: str) -> Any:
    def check(v: Any) -> str | None:
        ok = (isinstance(v, list) and len(v) == 2
              and all(isinstance(x, int) and not isinstance(x, bool) for x in v)
              and 1 <= v[0] <= v[1])
        return None if ok else f"must be {what}"
    return check


def _prob(strict_top: bool) -> Any:
    def check(v: Any) -> str | None:
        if v <= 0:
            return "must be a number > 0"
        if strict_top and v >= 1:
            return "must be < 1"
        return None if v <= 1 else "must be <= 1"
    return check


#: the track manager's ``[tracker]`` keys (beside the TMA filter's and the sub-tables)
MANAGER_PARAMS = Schema({
    "measurements": Param("str", "bearings", "what the tracks are made of",
                          choices=("bearings", "lines+bearings", "lines", "contacts",
                                   "positions", "fused_bearings")),
    "association": Param("str", "gnn", "global nearest neighbour or joint probabilistic data "
                         "association", choices=("gnn", "jpda")),
    "gate_prob": Param("float", 0.999, "P_G of the χ² gate", check=_prob(True)),
    "confirm": Param("any", [3, 5], "[M, N]: M hits in N scans confirm a track",
                     check=_int_pair("[M, N] integers, 1 <= M <= N")),
    "max_misses": Param("int", 5, "consecutive missed scans before a confirmed track is "
                        "deleted", check=lambda v: None if v >= 1 else "must be an integer >= 1"),
    "hit_window": Param("any", None, "optional [K, W]: delete a confirmed track with fewer than "
                        "K hits in W scans", check=_int_pair(
                            "[K, W] integers, 1 <= K <= W (delete a confirmed track with fewer "
                            "than K hits in W scans)")),
    "pd": Param("float", 0.9, "JPDA detection probability", check=_prob(False)),
    "clutter_density": Param("float", 1e-3, "JPDA false measurements per unit of measurement "
                             "space", check=positive),
}, "the multi-target track manager ([tracker] table, type = \"multi\")")


def _sub_table(path: str, sub: str, given: Any) -> dict[str, Any]:
    if not isinstance(given, dict):
        raise ConfigError(f"{path}: tracker.{sub} must be a table")
    return Schema(SUB_PARAMS[sub]).check(given, path, prefix=f"tracker.{sub}.")


def check_multi_config(t: Any, path: str) -> tuple[dict[str, Any], dict[str, Any]]:
    """Check the ``[tracker]`` mapping of a multi-target tracker: (multi settings, the
    single-mode keys for the TMA filter, checked by
    :func:`arrayproc.track.single.check_single_config`)."""
    from arrayproc.track.single import check_single_config
    t = legacy_table(t, path)
    if not isinstance(t, dict):
        raise ConfigError(f"{path}: missing [tracker] table")
    multi = {k: t[k] for k in MULTI_KEYS if k in t}
    single = {k: v for k, v in t.items() if k not in MULTI_KEYS}
    top = {k: v for k, v in multi.items() if k not in SUB_PARAMS and k != "mode"}
    cfg = MANAGER_PARAMS.check(top, path, prefix="tracker.")
    cfg["confirm"] = MofN(*cfg["confirm"])
    for sub in SUB_PARAMS:
        cfg[sub] = _sub_table(path, sub, multi.get(sub, {}))
    return cfg, check_single_config(single, path)
