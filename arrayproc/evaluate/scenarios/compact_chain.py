"""The compact-array chain end to end: simulated tetrahedral recordings of one vessel, then two
vessels passing at once, through the shipped files only (``simulate → process → track →
tma``), scored per vessel.

The set-up is the compact-array paper's: a 1.84 m tetrahedron on the bed (centroid at
166.5 m, the bed at 168 m), vessels at 4 m depth moving straight at the paper's mean speed of
7.3 m/s, broadband level by the SPL paper's speed law with two blade-rate tonals (as
``arrayproc/data/scenarios/tetrahedral_compact.toml``). The array's heading jitters as a
first-order Gauss-Markov yaw (``[array] yaw_std`` = 1°, ``yaw_time`` = 20 s) that ``/nav``
does not see, so the azimuths carry exponentially correlated errors with a known τ = 20 s,
which the TMA estimates from each track's residuals.

Vessel ``a`` passes north of the array heading east with its CPA ``cpa`` at mid-record;
with two vessels, ``b`` passes south heading west at 1.5 × ``cpa`` (3.5 dB weaker by
spherical spreading), its CPA at the same time. The record lasts while the nearer vessel's
azimuth sweeps ±60° about its CPA (2 cpa tan 60° / v), at least 240 s and at most 900 s.

Per vessel (:func:`score_run`): whether a confirmed track follows it (the median azimuth
error of the track's own rows within ``follow_deg`` of the vessel's true azimuth at those
times) and has a TMA solution; that solution at the vessel's true CPA time (the state
propagated with constant velocity, the CRLB with it) against the truth: the position error
in σ of the CRLB (Mahalanobis, 2-D; ≤ 3 the target) and as a percentage of the CPA range
(≤ 20 % the target); the correlation time estimated (``tau_s ± tau_sigma_s``) against the
one simulated. Confirmed tracks that follow no vessel are counted as false tracks.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from arrayproc.io.products import read_products
from arrayproc.io.schema import groups_of_kind

__all__ = ["SPEED", "YAW_STD", "YAW_TIME", "SHIPPED", "duration_s", "vessels",
           "scenario_toml", "run_chain", "score_run", "run_case"]

SPEED = 7.3            # m/s, the paper's mean vessel speed
YAW_STD = 1.0          # deg, the array's heading jitter
YAW_TIME = 20.0        # s, its correlation time
FAR_FACTOR = 1.5       # the second vessel's CPA range over the first's
HEADING = 30.0         # deg, the array's x axis
SOURCE_DEPTH = 4.0     # m
ARRAY_DEPTH = 166.5    # m, the tetrahedron's centroid (base 0.4 m above the 168 m bed)

#: the shipped files the chain runs through (names under ``arrayproc data-dir``)
SHIPPED = {"chain": "chains/compact_bearings.toml", "tracker": "trackers/compact_multi.toml",
           "tma": "tma/compact_tracks.toml"}


def duration_s(cpa: float) -> float:
    """Record length (s): the nearer vessel's azimuth ±60° about its CPA, in [240, 900] s."""
    return float(min(max(2.0 * cpa * math.tan(math.radians(60.0)) / SPEED, 240.0), 900.0))


def vessels(cpa: float, n: int) -> list[dict[str, Any]]:
    """The ``n`` (1 or 2) vessels of a run: name, CPA range (m), course (deg), start (m),
    CPA time (s)."""
    if n not in (1, 2):
        raise ValueError(f"1 or 2 vessels, not {n}")
    half = 0.5 * duration_s(cpa)
    out = [{"name": "a", "cpa_m": float(cpa), "course": 90.0,
            "start": [-SPEED * half, float(cpa)], "t_cpa": half}]
    if n == 2:
        out.append({"name": "b", "cpa_m": FAR_FACTOR * cpa, "course": 270.0,
                    "start": [SPEED * half, -FAR_FACTOR * cpa], "t_cpa": half})
    return out


def scenario_toml(cpa: float, n_vessels: int, seed: int, yaw_std: float = YAW_STD,
                  yaw_time: float = YAW_TIME) -> str:
    """The scenario file of one run (the layout of ``tetrahedral_compact.toml``)."""
    src = []
    for v in vessels(cpa, n_vessels):
        src.append(f"""
[[source]]
name = "{v['name']}"
start = [{v['start'][0]:.3f}, {v['start'][1]:.3f}]
depth = {SOURCE_DEPTH}
course = {v['course']}
speed = {SPEED}
tonals = [{{ freq = 11.5, level_db = 160.0 }}, {{ freq = 23.0, level_db = 155.0 }}]
[source.broadband]
band = [50.0, 3500.0]
model = "speed"
""")
    return f"""# compact-array chain: {n_vessels} vessel(s), CPA {cpa:g} m, seed {seed}
[recording]
fs = 8000.0
duration = {duration_s(cpa):.3f}
sound_speed = 1480.0
seed = {int(seed)}

[array]
type = "tetrahedron"
side = 1.84
depth = {ARRAY_DEPTH}
yaw_std = {yaw_std}
yaw_time = {yaw_time}

[ownship]
start = [0.0, 0.0]
heading = {HEADING}
{''.join(src)}
[noise]
spectrum = [[20.0, 75.0], [200.0, 65.0], [2000.0, 55.0], [3600.0, 52.0]]
"""


def _shipped(key: str) -> str:
    from arrayproc.data import data_path
    return str(data_path(*SHIPPED[key].split("/")))


def run_chain(workdir: str | os.PathLike, scenario_text: str) -> dict[str, str]:
    """``simulate → process → track → tma`` through the library functions the commands call
    (:mod:`arrayproc.evaluate.pipeline`) and the shipped files (:data:`SHIPPED`); returns the
    paths written."""
    import warnings

    from arrayproc.evaluate import pipeline as commands

    d = Path(workdir)
    d.mkdir(parents=True, exist_ok=True)
    paths = {k: str(d / f"{k}.h5") for k in ("rec", "brg", "trk", "tma")}
    (d / "scenario.toml").write_text(scenario_text, encoding="utf-8")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # aliasing above c/2d, tracks too short to solve
        commands.simulate(str(d / "scenario.toml"), paths["rec"])
        commands.process(paths["rec"], _shipped("chain"), paths["brg"])
        commands.track(paths["brg"], _shipped("tracker"), paths["trk"])
        commands.tma(paths["trk"], _shipped("tma"), paths["tma"])
    return paths


def _truth(rec: str) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    with h5py.File(rec, "r") as f:
        g = f["truth/sources"]
        return {n: (g[n]["time"][:], g[n]["position"][:]) for n in g}


def _true_azimuth(truth: tuple[np.ndarray, np.ndarray], t: np.ndarray) -> np.ndarray:
    tt, p = truth
    return np.degrees(np.arctan2(np.interp(t, tt, p[:, 0]), np.interp(t, tt, p[:, 1])))


def _track_rows(trk: str, brg: str) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """Every confirmed track's own rows: id → (time, azimuth deg)."""
    g = read_products(trk)["tracks"]
    b = read_products(brg)[groups_of_kind(read_products(brg), "bearings")[0]]
    ids = np.asarray(g["track_id"]).reshape(-1)
    st = np.asarray(g["status"]).reshape(-1)
    rows = np.asarray(g["row"]).reshape(-1)
    bt, baz = np.asarray(b["time"], float), np.asarray(b["azimuth_deg"], float)
    out = {}
    for tid in np.unique(ids[st == 1]):
        r = np.unique(rows[(ids == tid) & (rows >= 0)])
        out[int(tid)] = (bt[r], baz[r])
    return out


def _solution_at(row: dict[str, Any], t: float) -> tuple[np.ndarray, np.ndarray]:
    """Position (2,) and its CRLB (2, 2) of a tma row at time t (constant velocity)."""
    dt = t - row["t0"]
    f = np.eye(4)
    f[0, 2] = f[1, 3] = dt
    x = f @ np.array([row["x"], row["y"], row["vx"], row["vy"]])
    p = f @ row["crlb"] @ f.T
    return x[:2], p[:2, :2]


def score_run(paths: dict[str, str], cpa: float, n_vessels: int, follow_deg: float = 5.0,
              yaw_time: float = YAW_TIME) -> dict[str, Any]:
    """Per vessel: held, the solution's error in CRLB σ and in % of the CPA range, τ̂ ± se;
    and the false tracks (module doc)."""
    truth = _truth(paths["rec"])
    tracks = _track_rows(paths["trk"], paths["brg"])
    tg = read_products(paths["tma"])["tma"]
    sols = {int(tid): {k: np.asarray(tg[k])[i] for k in ("t0", "t1", "x", "y", "vx", "vy",
                                                          "crlb", "tau_s", "tau_sigma_s")}
            for i, tid in enumerate(np.asarray(tg["track_id"]).reshape(-1))}
    follows: dict[int, str | None] = {}
    for tid, (t, az) in tracks.items():
        best, err = None, follow_deg
        for name, tr in truth.items():
            e = float(np.median(np.abs((az - _true_azimuth(tr, t) + 180.0) % 360.0 - 180.0)))
            if e < err:
                best, err = name, e
        follows[tid] = best
    out: dict[str, Any] = {"cpa_m": cpa, "n_vessels": n_vessels, "vessels": {},
                           "confirmed_tracks": len(tracks),
                           "false_tracks": sum(v is None for v in follows.values()),
                           "false_tracks_solved": sum(v is None and k in sols
                                                      for k, v in follows.items())}
    for v in vessels(cpa, n_vessels):
        mine = [k for k, name in follows.items() if name == v["name"] and k in sols]
        rec: dict[str, Any] = {"cpa_m": v["cpa_m"], "tracks": sum(
            name == v["name"] for name in follows.values()), "held": bool(mine)}
        if mine:
            k = max(mine, key=lambda i: tracks[i][0].size)  # the longest solved track
            s = sols[k]
            tc = float(np.clip(v["t_cpa"], s["t0"], s["t1"]))
            pos, p = _solution_at(s, tc)
            tt, tp = truth[v["name"]]
            true = np.array([np.interp(tc, tt, tp[:, 0]), np.interp(tc, tt, tp[:, 1])])
            e = pos - true
            rec.update(track_id=k, rows=int(tracks[k][0].size),
                       span_s=float(tracks[k][0][-1] - tracks[k][0][0]),
                       err_m=float(np.hypot(*e)),
                       err_sigma=float(np.sqrt(e @ np.linalg.solve(p, e))),
                       err_pct_cpa=float(100.0 * np.hypot(*e) / v["cpa_m"]),
                       crlb_m=float(np.sqrt(np.trace(p))),
                       tau_s=float(s["tau_s"]), tau_sigma_s=float(s["tau_sigma_s"]),
                       tau_true_s=yaw_time)
        out["vessels"][v["name"]] = rec
    return out


def run_case(workdir: str | os.PathLike, cpa: float, n_vessels: int, seed: int,
             keep: bool = False) -> dict[str, Any]:
    """One run: scenario, the chain through the shipped files, the scores; the recording and
    products are removed unless ``keep``."""
    d = Path(workdir) / f"v{n_vessels}_cpa{cpa:g}_s{seed}"
    paths = run_chain(d, scenario_toml(cpa, n_vessels, seed))
    out = score_run(paths, cpa, n_vessels)
    out["seed"] = int(seed)
    if not keep:
        for p in paths.values():
            Path(p).unlink(missing_ok=True)
    return out
