"""Two static compact arrays, two vessels: the fused multi-target tracker
(``trackers/compact_fused.toml``, :mod:`arrayproc.track.multi.fused`) scored against the truth.

Measurement level: each array's products file holds its azimuth rows (one per vessel per
scan of 2.048 s, detected with probability ``pd``, σ ``sigma_deg``; plus at most one clutter
row per scan, uniform in azimuth, with probability ``clutter``) and names its recording,
whose ``/nav`` places the array (:func:`.two_array_fusion.write_array_products`). The
tracker runs through the command line (``arrayproc track A.h5 B.h5 -c …``).

Scores per vessel, over the scan times of the tracks file: **held share** (times at which a
confirmed track lies within ``hold_m`` of the vessel, the nearest such track taken), the
**position RMSE** and the **NEES** of the position covariance (2 dof) over the held points;
and **false tracks**: confirmed tracks less than half of whose confirmed points lie within
``hold_m`` of a vessel.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from arrayproc.evaluate.scenarios.two_array_fusion import write_array_products

__all__ = ["SITES", "vessel_truth", "write_fused_case", "score_fused", "run_fused_case",
           "nees_band"]

#: the arrays' positions (m): a 2 km baseline on the x axis
SITES = np.array([[0.0, 0.0], [2000.0, 0.0]])
#: the vessels' starts (m) and velocities (m/s): one passing east north of the arrays, one
#: south-west beyond it; their tracks never come within 1 km
VESSELS = (((-1500.0, 1500.0), (4.0, 0.0)), ((3500.0, 3000.0), (-3.0, -0.5)))
SCAN_S = 2.048
DURATION_S = 600.0


def vessel_truth(t: np.ndarray) -> np.ndarray:
    """States (K, n, 4) [x, y, ẋ, ẏ] of the vessels at times ``t`` (s)."""
    out = []
    for p0, v in VESSELS:
        x = np.asarray(p0)[None] + np.asarray(v)[None] * np.asarray(t)[:, None]
        out.append(np.hstack([x, np.tile(v, (t.size, 1))]))
    return np.stack(out)


def write_fused_case(folder: str | os.PathLike, rng: np.random.Generator,
                     sigma_deg: float = 1.0, pd: float = 0.9, clutter: float = 0.3,
                     duration: float = DURATION_S) -> list[str]:
    """Write each array's recording and products file (module doc); the second array's
    scans lag the first's by half a scan. Returns the products paths."""
    paths = []
    for a, site in enumerate(SITES):
        t = np.arange(0.0, duration, SCAN_S) + 0.5 * SCAN_S * a
        X = vessel_truth(t)
        rel = X[:, :, :2] - site[None, None]
        az = np.degrees(np.arctan2(rel[..., 0], rel[..., 1]))
        az = az + rng.normal(0.0, sigma_deg, az.shape)
        az[rng.random(az.shape) >= pd] = np.nan
        cl = np.where(rng.random(t.size) < clutter, rng.uniform(0, 360, t.size), np.nan)
        paths.append(write_array_products(folder, f"array{a}", site, t, np.vstack([az, cl])))
    return paths


def nees_band(n: int, dof: int = 2, p: float = 0.95) -> tuple[float, float]:
    """Two-sided ``p`` band of a mean of ``n`` independent χ²(dof) NEES values
    (BLK 2001 sec. 5.4.2)."""
    from scipy.stats import chi2
    lo, hi = chi2.ppf([(1 - p) / 2, (1 + p) / 2], dof * n)
    return float(lo / n), float(hi / n)


def score_fused(tracks_path: str, hold_m: float = 250.0) -> dict[str, Any]:
    """Scores of one tracks file against :func:`vessel_truth` (module doc): per vessel
    ``held`` (share), ``sq_err`` and ``nees`` (arrays over the held points); ``false``."""
    from arrayproc.io.products import read_products

    g = read_products(tracks_path)["tracks"]
    t = np.asarray(g["time"], float)
    conf = np.asarray(g["status"]) == 1
    ids = np.asarray(g["track_id"])
    xy = np.stack([np.asarray(g["x"], float), np.asarray(g["y"], float)], 1)
    C = np.asarray(g["cov"], float)[:, :2, :2]
    times = np.unique(t)
    truth = vessel_truth(times)
    where = np.searchsorted(times, t)
    out: dict[str, Any] = {"vessels": []}
    near_any = np.zeros(t.size, bool)
    for k in range(truth.shape[0]):
        e = xy - truth[k, where, :2]
        d = np.hypot(e[:, 0], e[:, 1])
        ok = conf & (d < hold_m)
        near_any |= ok
        held, se, nees = 0, [], []
        for i in np.unique(where[ok]):
            m = np.flatnonzero(ok & (where == i))
            j = m[np.argmin(d[m])]
            held += 1
            se.append(d[j] ** 2)
            nees.append(float(e[j] @ np.linalg.solve(C[j], e[j])))
        out["vessels"].append({"held": held / times.size, "sq_err": np.array(se),
                               "nees": np.array(nees)})
    false = 0
    for i in np.unique(ids[conf]):
        m = conf & (ids == i)
        false += int(near_any[m].mean() < 0.5)
    out["false"] = false
    return out


def run_fused_case(seeds: list[int], config: str,
                   track: Callable[[list[str], str, str], None], **case: Any
                   ) -> dict[str, Any]:
    """Write and track one case per seed (``track(inputs, config, output)``, e.g. the
    command line) and gather the scores: per vessel the mean held share, the position RMSE
    and mean NEES over every held point of every seed, the per-time-averaged NEES's 95 %
    band for that many seeds; false tracks per seed."""
    runs = []
    for s in seeds:
        rng = np.random.default_rng(s)
        with tempfile.TemporaryDirectory() as tmp:
            paths = write_fused_case(tmp, rng, **case)
            out = str(Path(tmp) / "tracks.h5")
            track(paths, config, out)
            runs.append(score_fused(out))
    res: dict[str, Any] = {"seeds": len(seeds), "vessels": [],
                           "false_per_seed": float(np.mean([r["false"] for r in runs])),
                           "false_max": int(max(r["false"] for r in runs)),
                           "nees_band": nees_band(len(seeds))}
    for k in range(len(VESSELS)):
        v = [r["vessels"][k] for r in runs]
        se = np.concatenate([x["sq_err"] for x in v])
        ne = np.concatenate([x["nees"] for x in v])
        res["vessels"].append({
            "held": float(np.mean([x["held"] for x in v])),
            "held_min": float(min(x["held"] for x in v)),
            "rmse_m": float(np.sqrt(se.mean())) if se.size else float("nan"),
            "nees": float(ne.mean()) if ne.size else float("nan")})
    return res
