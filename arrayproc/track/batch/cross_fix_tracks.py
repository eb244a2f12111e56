"""``arrayproc tma TRK_A.h5 TRK_B.h5 -c cross_fix``: tracks of two static arrays paired by
their joint cross-fix fit, one solution per pair.

Each input is a multi-target tracks file of one static array (``arrayproc track … -c
compact_multi``; :func:`.per_track.read_track_rows` reads each confirmed track's own rows).
The array's position is its recording's (the tracks file's ``recording``, else the products'
``source``; :func:`.cross_fix_run.array_position`). A track of array A and one of array B
are a candidate pair when their rows overlap for ``tma.min_duration_s`` with ``tma.min_rows``
rows of each in the overlap. Each candidate is fitted by :func:`.cross_fix.solve_cross_fix`
over the overlap, every row with its track's σ: ``tma.sigma_bearing_deg``, or (0) the
track's own scatter, ``σ̂ = 1.4826 · median|Δ²y| / √6`` over its consecutive rows
(:func:`difference_sigma`: the second differences of a smooth bearing are its noise's, of
variance 6σ², whatever the pairing). Its cost per degree of freedom ``q = cost / (N − 4)``
is ≈ 1 for one target's tracks and grows when the two tracks are of different targets (no
one straight track fits both arrays' bearings). The pairs are taken one-to-one in increasing
``q`` while ``q ≤ tma.pair_cost``; each pair's solution is then that of
:func:`.cross_fix_run.solve_estimated_sigma` (σ from the residuals) or of the configured σ.
A track left unpaired is named in a warning.

Limits: two arrays; the second-difference σ is the white part of the bearing errors (errors
correlated over many rows, e.g. a compact array's yaw, raise every pair's ``q``: give
``tma.sigma_bearing_deg`` then); a wrong pair fits as well as the right one when both
targets' bearing tracks are nearly straight lines over the overlap.
"""
from __future__ import annotations

import logging
import os
import warnings
from typing import Any

import numpy as np

from arrayproc.errors import ConfigError, FormatError
from arrayproc.io.products import read_products
from arrayproc.io.text import as_text

from .cross_fix import solve_cross_fix
from .cross_fix_run import array_position, named_recording, solve_estimated_sigma
from .per_track import read_track_rows
from .result import TmaSolution
from .run import true_bearings, warn_if_far_from, write_tma

_log = logging.getLogger(__name__)

__all__ = ["difference_sigma", "pair_candidates", "run_cross_fix_tracks"]


def difference_sigma(t: np.ndarray, y: np.ndarray) -> float:
    """A bearing track's white-noise σ (rad) from its rows' second differences:
    ``1.4826 · median|y[i+1] − 2 y[i] + y[i−1]| / √6`` (unwrapped, rows in time order)."""
    v = np.unwrap(np.asarray(y, float)[np.argsort(t, kind="stable")])
    d2 = v[2:] - 2.0 * v[1:-1] + v[:-2]
    return max(float(1.4826 * np.median(np.abs(d2)) / np.sqrt(6.0)), 1e-6)


def _array_tracks(path: str, cfg: dict[str, Any]) -> dict[str, Any]:
    """One tracks file's confirmed tracks (time, bearing, σ) and its array's position."""
    tr = read_track_rows(path, cfg)
    rec = named_recording(path, tr.recording or as_text(
        read_products(tr.products)["/"].get("source", "")))
    tracks = {}
    for tid, m in tr.tracks.items():
        y = true_bearings(m, np.ones(m["time"].size, bool), dict(cfg, method="cross_fix"))
        sig = (np.deg2rad(cfg["sigma_bearing_deg"]) if cfg["sigma_bearing_deg"] > 0 else
               difference_sigma(m["time"], y) if m["time"].size >= 3 else np.nan)
        tracks[tid] = {"time": m["time"], "bearing": y, "sigma": sig}
    t_all = np.concatenate([m["time"] for m in tracks.values()])
    return {"tracks": tracks, "xy": array_position(path, rec, np.unique(t_all)),
            "recording": rec, "path": path, "products": tr.products}


def _overlap(a: dict, b: dict, cfg: dict[str, Any]) -> tuple[float, float] | None:
    w0 = max(a["time"][0], b["time"][0])
    w1 = min(a["time"][-1], b["time"][-1])
    if w1 - w0 < cfg["min_duration_s"]:
        return None
    for m in (a, b):
        if np.sum((m["time"] >= w0) & (m["time"] <= w1)) < cfg["min_rows"]:
            return None
    return float(w0), float(w1)


def _stack(arrays: list[dict], ids: tuple[int, int], w0: float, w1: float,
           sig_of: str = "sigma") -> tuple[np.ndarray, ...]:
    """Times, bearings, positions, σ and array indices of the two tracks' rows in [w0, w1]."""
    parts = []
    for k, (arr, tid) in enumerate(zip(arrays, ids, strict=True)):
        m = arr["tracks"][tid]
        sel = (m["time"] >= w0) & (m["time"] <= w1)
        parts.append((m["time"][sel], m["bearing"][sel], np.tile(arr["xy"], (sel.sum(), 1)),
                      np.full(sel.sum(), m[sig_of]), np.full(sel.sum(), k)))
    return tuple(np.concatenate([p[i] for p in parts]) for i in range(5))


def pair_candidates(arrays: list[dict], cfg: dict[str, Any]
                    ) -> list[tuple[float, int, int, float, float]]:
    """Every candidate pair of tracks (module doc) as ``(q, id_a, id_b, w0, w1)``, in
    increasing cost per degree of freedom ``q``."""
    out = []
    for ia, a in arrays[0]["tracks"].items():
        for ib, b in arrays[1]["tracks"].items():
            w = _overlap(a, b, cfg)
            if w is None or not (np.isfinite(a["sigma"]) and np.isfinite(b["sigma"])):
                continue
            t, y, obs, sig, _ = _stack(arrays, (ia, ib), *w)
            try:
                sol = solve_cross_fix(t, y, obs, sig, t0=w[0], t1=w[1])
            except (ValueError, np.linalg.LinAlgError):
                continue
            out.append((sol.cost / max(t.size - 4, 1), ia, ib, *w))
    return sorted(out)


def run_cross_fix_tracks(tracks_paths: list[str], config_path: str, output_path: str,
                         progress: bool = False) -> list[tuple[tuple[int, int], TmaSolution]]:
    """Pair two static arrays' tracks and solve each pair by cross-fix; write a ``tma`` group.

    Parameters
    ----------
    tracks_paths : list of str
        Two tracks files, one per array (module doc).
    config_path : str
        TMA TOML with ``method = "cross_fix"``.
    output_path : str
        Products file to write: one ``tma`` row per pair, ``track_id`` (the first file's
        track) and ``pair_track_id`` (the second's).
    progress : bool
        One line per solution on stderr.

    Returns
    -------
    list of ((int, int), TmaSolution)
    """
    from .run import load_tma_config
    cfg = load_tma_config(config_path)
    if cfg["method"] != "cross_fix":
        raise ConfigError(f"{config_path}: tma.method = {cfg['method']!r} reads one tracks "
                          f"file; {len(tracks_paths)} were given (several: method = "
                          "'cross_fix')")
    if len(tracks_paths) != 2:
        raise ConfigError(f"{config_path}: cross_fix pairs the tracks of two tracks files; "
                          f"{len(tracks_paths)} given")
    arrays = [_array_tracks(p, cfg) for p in tracks_paths]
    sites = np.stack([a["xy"] for a in arrays])
    if np.hypot(*(sites[0] - sites[1])) < 1.0:
        raise FormatError(f"{tracks_paths[0]} and {tracks_paths[1]}: the arrays are at the "
                          "same position (within 1 m): no cross-fix")
    used_a, used_b, out = set(), set(), []
    for q, ia, ib, w0, w1 in pair_candidates(arrays, cfg):
        if q > cfg["pair_cost"] or ia in used_a or ib in used_b:
            continue
        used_a.add(ia)
        used_b.add(ib)
        t, y, obs, sig, site = _stack(arrays, (ia, ib), w0, w1)
        sol = (solve_cross_fix(t, y, obs, sig, t0=w0, t1=w1) if cfg["sigma_bearing_deg"] > 0
               else solve_estimated_sigma(t, y, obs, site, w0, w1))
        out.append(((ia, ib), sol))
        warn_if_far_from(sol, sites, cfg, f"cross_fix tracks {ia} and {ib}")
        if progress:
            _log.info(f"tma cross_fix tracks {ia} + {ib} (cost/dof {q:.2f}): x "
                      f"{sol.state[0]:9.1f} y {sol.state[1]:9.1f} m, course "
                      f"{sol.heading_deg:5.1f} deg, speed {sol.speed_mps:5.2f} m/s")
    for k, used in ((0, used_a), (1, used_b)):
        left = sorted(set(arrays[k]["tracks"]) - used)
        if left:
            warnings.warn(f"{tracks_paths[k]}: tracks {', '.join(map(str, left))} not paired "
                          f"(no track of the other array within tma.pair_cost = "
                          f"{cfg['pair_cost']:g} over an overlap of tma.min_rows rows and "
                          "tma.min_duration_s)", stacklevel=2)
    if not out:
        raise FormatError(f"{tracks_paths[0]}, {tracks_paths[1]}: no pair of tracks within "
                          f"tma.pair_cost = {cfg['pair_cost']:g}")
    write_tma(output_path, [s for _, s in out], arrays[0]["recording"], cfg,
              root_attrs={"tracks": "\n".join(os.path.abspath(p) for p in tracks_paths)},
              track_ids=[p[0] for p, _ in out], pair_ids=[p[1] for p, _ in out],
              tracks="\n".join(os.path.abspath(p) for p in tracks_paths),
              recordings="\n".join(a["recording"] for a in arrays),
              array_x_m=sites[:, 0], array_y_m=sites[:, 1])
    return out
