"""TMA with bearings and sound pressure levels from a recording (SPL paper, section 5.1).

The paper's manoeuvring scenario as a 64-hydrophone recording (shipped scenario
``tma_spl_paper``: source level eq. (12), the bundled bellhopcxx TL table) goes through
``simulate → process → track`` (:mod:`arrayproc.evaluate.pipeline`): the shipped chain
``spl_tma`` gives one bearing and one received level (``spl_db``) every 60 s, and the
single-target tracker's regularised particle filter (SPL paper eqs. (17)-(30)) runs twice on
the same products, bearings only and with levels (likelihood eqs. (31)-(33)). Per seed the
products are scored against the simulator's truth:

* the level error ``spl_db − (SL − TL)``: SL the truth's source level (eq. (12), at emission)
  and TL the table's loss at the true range (:func:`true_received_level`);
* the bearing error of the pair member nearer the truth, against the true bearing of the
  retarded source position (:func:`true_bearings`);
* the position error of the two tracks at the row times.

:func:`measurement_level` runs the paper's measurement-level Monte Carlo
(:func:`arrayproc.evaluate.scenarios.spl_paper.rpf_monte_carlo`) for comparison, with the
paper's σ's or with errors measured on the recordings. Diagnostics: the bearing error that
the arrival's elevation gives a line array (:func:`integration_sweeps`), the products with
shorter integrations (:func:`integration_check`) and the RPF fed the true member of each
left-right pair (:func:`known_side_errors`).
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from arrayproc.acoustics.tl.table import TLTable, load_default_table
from arrayproc.data import data_path
from arrayproc.evaluate import pipeline
from arrayproc.evaluate.accuracy import rmse
from arrayproc.evaluate.chains import toml_value
from arrayproc.geo.angles import true_bearing
from arrayproc.io.products import read_products
from arrayproc.io.recording import Recording

__all__ = ["SCENARIO", "CHAIN", "TL_NAME", "recording_truth", "true_bearings",
           "true_received_level", "product_errors", "tracker_toml", "run_seed",
           "summarise", "measurement_level", "cached_seed",
           "integration_sweeps", "SEGMENTS", "known_side_errors",
           "integration_check"]

SCENARIO = "tma_spl_paper"
CHAIN = "spl_tma"
TL_NAME = "munk_bellhopcxx_incoherent"
#: the paper's filter (section 5): σ_θ 1.5°, σ_l 10 dB in the likelihood, σ_a 1.5e-3 m/s²,
#: prior range 10 ± 2 km, speed 3 ± 2 kn, course z₀ + π ± π/√12
FILTER = {"sigma_bearing_deg": 1.5, "range_m": 10e3, "sigma_range_m": 2e3,
          "speed_mps": 3 * 0.514444, "sigma_speed_mps": 2 * 0.514444,
          "sigma_course_deg": float(np.rad2deg(np.pi / np.sqrt(12.0)))}
SIGMA_A = 1.5e-3
SIGMA_LEVEL_FILTER_DB = 10.0


def recording_truth(rec_path: str) -> dict[str, Any]:
    """The simulator's truth of the one source ``target`` and of the array.

    Returns
    -------
    dict
        ``time`` (n,) s; ``position``, ``velocity`` (n, 2) m, m/s of the target;
        ``source_level_db`` (n,) its in-band source level (eq. (12), dB re 1 µPa @ 1 m);
        ``depth`` m; ``own_position`` (n, 2) m and ``own_depth`` m of the array's reference
        point; ``sound_speed`` m/s.
    """
    with Recording(rec_path) as r:
        src = r.read_group("truth/sources/target")
        own = r.read_group("truth/ownship")
        c = float(r.sound_speed)
    if not np.array_equal(src["time"], own["time"]):
        raise ValueError(f"{rec_path}: target and ownship truths on different times")
    return {"time": np.asarray(src["time"], float), "position": np.asarray(src["position"]),
            "velocity": np.asarray(src["velocity"]),
            "source_level_db": np.asarray(src["broadband_source_level_db"], float),
            "depth": float(src["attrs"]["depth"]), "own_position": np.asarray(own["position"]),
            "own_depth": float(np.mean(own["depth"])), "sound_speed": c}


def _interp(t: np.ndarray, tt: np.ndarray, v: np.ndarray) -> np.ndarray:
    v = np.asarray(v, float)
    if v.ndim == 1:
        return np.interp(t, tt, v)
    return np.stack([np.interp(t, tt, v[:, i]) for i in range(v.shape[1])], axis=1)


def true_bearings(truth: dict[str, Any], t: np.ndarray) -> tuple[np.ndarray, np.ndarray,
                                                                  np.ndarray]:
    """True bearing, range and emission time of the sound received at times ``t``.

    The wave received at t left the source at t − τ, τ = |p(t − τ) − o(t)| / c (slant range,
    solved by fixed-point iteration); the bearing is that of the retarded position.

    Returns
    -------
    bearing_deg : (K,) ndarray
        deg true, [0, 360).
    range_m : (K,) ndarray
        Horizontal range of the retarded position, m.
    t_emit : (K,) ndarray
        Emission times, s.
    """
    t = np.asarray(t, float)
    own = _interp(t, truth["time"], truth["own_position"])
    dz = truth["own_depth"] - truth["depth"]
    tau = np.zeros_like(t)
    for _ in range(4):
        p = _interp(t - tau, truth["time"], truth["position"])
        tau = np.sqrt(np.sum((p - own) ** 2, axis=1) + dz * dz) / truth["sound_speed"]
    d = _interp(t - tau, truth["time"], truth["position"]) - own
    return np.rad2deg(true_bearing(d[:, 0], d[:, 1])), np.hypot(d[:, 0], d[:, 1]), t - tau


def true_received_level(truth: dict[str, Any], t: np.ndarray, tab: TLTable) -> np.ndarray:
    """True received level (dB re 1 µPa²) at times ``t``: SL − TL, SPL paper eq. (11)/(15)
    without the noise; SL the source level at emission, TL the table's at the true range."""
    _, r, te = true_bearings(truth, t)
    sl = np.interp(te, truth["time"], truth["source_level_db"])
    return sl - tab(r, truth["depth"], truth["own_depth"])


def _strongest_per_time(products_path: str) -> tuple[Any, np.ndarray]:
    """The ``bearings`` group and the indices of its strongest row (``snr_db``) per time, in
    time order."""
    g = read_products(products_path)["bearings"]
    t = np.asarray(g["time"], float)
    order = np.lexsort((-np.asarray(g["snr_db"], float), t))
    return g, order[np.r_[True, t[order][1:] != t[order][:-1]]]


def product_errors(products_path: str, truth: dict[str, Any], tab: TLTable) -> dict[str, Any]:
    """Errors of the bearings rows against the truth, one row per time (the strongest by
    ``snr_db``, the tracker's choice).

    Returns
    -------
    dict
        ``time`` (K,) s; ``bearing_err_deg`` (K,): the pair member nearer the truth minus the
        true bearing, wrapped to (−180, 180]; ``level_err_db`` (K,): ``spl_db`` − true
        received level; ``snr_db`` (K,); ``true_side`` (K,) +1 when the starboard member is
        the nearer one, −1 port.
    """
    g, keep = _strongest_per_time(products_path)
    t = np.asarray(g["time"], float)[keep]
    snr = np.asarray(g["snr_db"], float)
    b_true, _, _ = true_bearings(truth, t)

    def wrap(a: np.ndarray) -> np.ndarray:
        return (a + 180.0) % 360.0 - 180.0

    e_p = wrap(np.asarray(g["bearing_port_deg"], float)[keep] - b_true)
    e_s = wrap(np.asarray(g["bearing_stbd_deg"], float)[keep] - b_true)
    stbd = np.abs(e_s) < np.abs(e_p)
    return {"time": t, "bearing_err_deg": np.where(stbd, e_s, e_p),
            "level_err_db": np.asarray(g["spl_db"], float)[keep]
            - true_received_level(truth, t, tab),
            "snr_db": snr[keep], "true_side": np.where(stbd, 1, -1)}


def tracker_toml(levels: bool, particles: int, seed: int) -> str:
    """The single-target tracker with the paper's RPF (section 5 settings, :data:`FILTER`):
    left-right resolution on the line array's pairs, bearings only or with ``spl_db``."""
    lines = ["[tracker]", 'type = "single"', 'filter = "rpf"', "lr = true", 'model = "cv"',
             "q1 = " + toml_value(SIGMA_A**2 * 60.0), "q2 = 0.0"]
    lines += [f"{k} = {toml_value(float(v))}" for k, v in FILTER.items()]
    if levels:
        lines.append('level = "spl_db"')
    lines += ["[tracker.params]", f"n_particles = {int(particles)}", f"seed = {int(seed)}",
              "sigma_a = " + toml_value(SIGMA_A)]
    if levels:
        lines += [f'tl_table = "{TL_NAME}"', "src_depth_m = 5.0", "rcv_depth_m = 300.0",
                  "sigma_level_db = " + toml_value(SIGMA_LEVEL_FILTER_DB)]
    return "\n".join(lines) + "\n"


def _track_error(tracks_path: str, truth: dict[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    g = read_products(tracks_path)["tracks"]
    t = np.asarray(g["time"], float)
    p = _interp(t, truth["time"], truth["position"])
    return t, np.hypot(np.asarray(g["x"]) - p[:, 0], np.asarray(g["y"]) - p[:, 1])


def run_seed(seed: int, workdir: str, duration: float | None = None, particles: int = 5000,
             keep: bool = False, log: Callable[[str], None] | None = None) -> dict[str, Any]:
    """One recording: simulate (``seed``), process with the ``spl_tma`` chain, score the
    products, track bearings only and with levels, score the tracks; the recording is
    deleted afterwards unless ``keep``.

    Returns
    -------
    dict
        ``seed``; ``time`` (K,) s of the rows; ``bearing_err_deg``, ``level_err_db``,
        ``snr_db``, ``true_side`` (K,) (:func:`product_errors`); ``err_bot_m``,
        ``err_spl_m`` (K,) position errors of the two tracks (NaN where a track has no row).
    """
    os.makedirs(workdir, exist_ok=True)
    rec = os.path.join(workdir, f"rec_{seed}.h5")
    prod = os.path.join(workdir, f"products_{seed}.h5")
    pipeline.simulate(str(data_path("scenarios", f"{SCENARIO}.toml")), rec, duration=duration,
                      seed=seed, warn=log)
    try:
        pipeline.process(rec, str(data_path("chains", f"{CHAIN}.toml")), prod, warn=log)
        truth = recording_truth(rec)
        out: dict[str, Any] = {"seed": int(seed)}
        out.update(product_errors(prod, truth, load_default_table(TL_NAME)))
        for label, levels in (("bot", False), ("spl", True)):
            with tempfile.NamedTemporaryFile("w", suffix=".toml", dir=workdir,
                                             delete=False) as f:
                f.write(tracker_toml(levels, particles, seed))
            tracks = os.path.join(workdir, f"tracks_{label}_{seed}.h5")
            try:
                pipeline.track(prod, f.name, tracks)
                tt, e = _track_error(tracks, truth)
            finally:
                os.unlink(f.name)
            err = np.full(out["time"].size, np.nan)
            idx = np.searchsorted(out["time"], tt)
            ok = (idx < err.size) & (out["time"][np.minimum(idx, err.size - 1)] == tt)
            err[idx[ok]] = e[ok]
            out[f"err_{label}_m"] = err
    finally:
        if not keep:
            Path(rec).unlink(missing_ok=True)
    return out


#: the three parts of the manoeuvring scenario by row time, min: first leg, turn, second leg
SEGMENTS = {"first leg (0-13 min)": (0.0, 13.0), "turn (13-17 min)": (13.0, 17.0),
            "second leg (17-30 min)": (17.0, 30.0)}


def integration_sweeps(times_s: np.ndarray, window_s: float = 60.0) -> dict[str, np.ndarray]:
    """The geometry of each row, from the scenario's tracks
    (:func:`~arrayproc.evaluate.scenarios.spl_paper.get_scenario` ``manoeuvring``, the same
    legs as ``tma_spl_paper.toml``).

    A horizontal line array measures the cone angle θ_c between its axis and the arrival,
    cos θ_c = cos β cos φ (β the horizontal relative bearing, φ the arrival's elevation,
    tan φ = Δz / r for the straight path between the depths); read as a horizontal bearing
    (heading ∓ θ_c) it is off by ``elevation_bearing_err_deg``.

    Returns
    -------
    dict
        ``bearing_sweep_deg``, ``heading_sweep_deg``: the change of the true bearing and of
        the array heading over [t − w/2, t + w/2] (deg); ``cone_deg``: |β| at t (deg);
        ``elevation_deg``: φ (deg); ``elevation_bearing_err_deg``: the bearing error the
        elevation alone gives (deg).
    """
    from arrayproc.evaluate.scenarios.spl_paper import get_scenario

    sc = get_scenario("manoeuvring")
    t = np.asarray(times_s, float)

    def bearing(tt: np.ndarray) -> np.ndarray:
        d = sc.truth(tt)[:, :2] - sc.observer_pos(tt)
        return np.rad2deg(np.arctan2(d[:, 0], d[:, 1]))

    def heading(tt: np.ndarray) -> np.ndarray:
        v = sc.observer.state(tt)[1]
        return np.rad2deg(np.arctan2(v[:, 0], v[:, 1]))

    def change(f: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
        return (f(t + 0.5 * window_s) - f(t - 0.5 * window_s) + 180.0) % 360.0 - 180.0

    rel = (bearing(t) - heading(t) + 180.0) % 360.0 - 180.0
    r = np.hypot(*(sc.truth(t)[:, :2] - sc.observer_pos(t)).T)
    phi = np.arctan2(sc.observer_depth_m - sc.target_depth_m, r)
    cone = np.rad2deg(np.arccos(np.cos(np.deg2rad(rel)) * np.cos(phi)))
    return {"bearing_sweep_deg": change(bearing), "heading_sweep_deg": change(heading),
            "cone_deg": np.abs(rel), "elevation_deg": np.rad2deg(phi),
            "elevation_bearing_err_deg": np.sign(rel) * (cone - np.abs(rel))}


def summarise(runs: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """RMSE against time over the seeds and the product errors, pooled and by segment.

    Returns
    -------
    dict
        ``time_min`` (K,); ``rmse_{bot,spl}_m`` (K,) over the seeds
        (:func:`arrayproc.evaluate.accuracy.rmse`) and the median final errors;
        ``level_err_*``/``bearing_err_*``: the mean (bias) and standard deviation pooled over
        rows and seeds, the mean over the seeds at each time (``*_mean_by_time``), the
        residual standard deviation about it (``*_residual_std``: the part that changes from
        seed to seed), the 95th percentile of the absolute error; ``segments``: the same
        mean/std for each part of :data:`SEGMENTS` that has rows; ``sweeps``:
        :func:`integration_sweeps`.
    """
    t = runs[0]["time"]
    if any(r["time"].shape != t.shape or np.any(r["time"] != t) for r in runs):
        raise ValueError("the seeds' rows are on different times")
    out: dict[str, Any] = {"seeds": [int(r["seed"]) for r in runs], "time_s": t.tolist(),
                           "time_min": (t / 60.0).tolist()}
    for label in ("bot", "spl"):
        e = np.stack([r[f"err_{label}_m"] for r in runs])
        out[f"rmse_{label}_m"] = rmse(e).tolist()
        out[f"median_final_error_{label}_m"] = float(np.median(e[:, -1]))
    errs = {"level_err": (np.stack([r["level_err_db"] for r in runs]), "db"),
            "bearing_err": (np.stack([r["bearing_err_deg"] for r in runs]), "deg")}
    tmin = t / 60.0
    out["segments"] = {}
    for name, (e, unit) in errs.items():
        m = e.mean(axis=0)
        out.update({f"{name}_mean_{unit}": float(e.mean()), f"{name}_std_{unit}": float(e.std()),
                    f"{name}_residual_std_{unit}": float((e - m).std()),
                    f"{name}_abs_p95_{unit}": float(np.percentile(np.abs(e), 95)),
                    f"{name}_mean_by_time_{unit}": m.tolist(),
                    f"{name}_std_by_time_{unit}": e.std(axis=0).tolist()})
        for seg, (lo, hi) in SEGMENTS.items():
            sel = (tmin >= lo) & (tmin < hi)
            if not sel.any():  # a shortened run: the segment has no rows
                continue
            d = out["segments"].setdefault(seg, {"rows": int(sel.sum())})
            d[f"{name}_mean_{unit}"] = float(e[:, sel].mean())
            d[f"{name}_std_{unit}"] = float(e[:, sel].std())
            d[f"{name}_max_abs_mean_{unit}"] = float(np.abs(m[sel]).max())
    out["snr_db_median"] = float(np.median(np.stack([r["snr_db"] for r in runs])))
    out["true_side"] = np.asarray(runs[0]["true_side"]).tolist()
    out["sweeps"] = {k: v.tolist() for k, v in integration_sweeps(t).items()}
    return out


def measurement_level(runs: int, particles: int, seed: int,
                      sigma_bearing_deg: float | None = None,
                      sigma_level_db: float | None = None,
                      offsets: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
                      ) -> dict[str, Any]:
    """The paper's measurement-level Monte Carlo of the manoeuvring scenario (section 5.1,
    :func:`~arrayproc.evaluate.scenarios.spl_paper.rpf_monte_carlo`): bearings eq. (8) and
    levels eq. (15) with the data σ's of the paper (1.5°, 4 dB) or the given ones, plus, with
    ``offsets``, a deterministic error at each time; the filter keeps the paper's σ_θ = 1.5°
    and σ_l = 10 dB.

    Parameters
    ----------
    runs, particles, seed
        Monte Carlo runs, particles of the RPF, root seed.
    sigma_bearing_deg, sigma_level_db : float, optional
        Standard deviations of the white errors of the data (default the paper's).
    offsets : (time_s, bearing_deg, level_db), optional
        Errors added to every run's bearings and levels, interpolated linearly onto the
        scenario's measurement times (held at the end values outside): the mean errors of the
        recordings' products at their row times (:func:`summarise`).

    Returns
    -------
    dict
        ``time_min`` (K,), ``rmse_{bot,spl}_m`` (K,), ``sigma_bearing_deg``,
        ``sigma_level_db`` (of the data), ``offsets`` (bool).
    """
    from arrayproc.evaluate.scenarios.spl_paper import get_scenario, rpf_monte_carlo

    sc = get_scenario("manoeuvring")
    if sigma_level_db is not None:
        sc.sigma_level_data_db = float(sigma_level_db)
    tab = load_default_table(TL_NAME)
    data = sc.simulate(runs, seed, tab)
    if sigma_bearing_deg is not None:  # redraw the bearings with the given σ, same truth
        rng = np.random.default_rng([seed, 99])
        d = data.truth[:, :2] - data.observer_pos
        b = np.rad2deg(true_bearing(d[:, 0], d[:, 1]))
        data.bearings_deg = (b + sigma_bearing_deg * rng.standard_normal(
            data.bearings_deg.shape)) % 360.0
    if offsets is not None:
        t_off, b_off, l_off = (np.asarray(x, float) for x in offsets)
        data.bearings_deg = (data.bearings_deg + np.interp(data.times, t_off, b_off)) % 360.0
        data.levels_db = data.levels_db + np.interp(data.times, t_off, l_off)
    res = rpf_monte_carlo(sc, data, tab, particles, seed)
    return {"runs": runs, "particles": particles, "seed": seed,
            "sigma_bearing_deg": float(sc.sigma_bearing_deg if sigma_bearing_deg is None
                                       else sigma_bearing_deg),
            "sigma_level_db": float(sc.sigma_level_data_db), "offsets": offsets is not None,
            "time_min": (sc.times / 60.0).tolist(), "rmse_bot_m": res["rmse_bot"].tolist(),
            "rmse_spl_m": res["rmse_spl"].tolist()}


def known_side_errors(products_path: str, particles: int, seed: int) -> dict[str, np.ndarray]:
    """Diagnostic: the same products and RPF without the left-right hypotheses, fed the
    member of each port/starboard pair nearer the truth (the unambiguous bearings the paper's
    measurement model has). Observer states from the scenario's legs
    (:func:`~arrayproc.evaluate.scenarios.spl_paper.get_scenario` ``manoeuvring``, the
    recording's navigation), truth likewise.

    Returns
    -------
    dict
        ``time`` (K,) s and ``err_{bot,spl}_m`` (K,) position errors.
    """
    from arrayproc.config import parse_toml
    from arrayproc.evaluate.scenarios.spl_paper import get_scenario
    from arrayproc.track.single import check_single_config, track_bearings

    sc = get_scenario("manoeuvring")
    g, keep = _strongest_per_time(products_path)
    t = np.asarray(g["time"], float)[keep]
    pos, vel = sc.observer.state(t)[:2]
    own = np.hstack([pos, vel])
    truth = sc.truth(t)
    d = truth[:, :2] - pos
    b_true = np.arctan2(d[:, 0], d[:, 1])
    pair = np.deg2rad(np.stack([np.asarray(g["bearing_port_deg"], float)[keep],
                                np.asarray(g["bearing_stbd_deg"], float)[keep]], axis=1))
    miss = np.abs(np.angle(np.exp(1j * (pair - b_true[:, None]))))
    z = np.angle(np.exp(1j * pair[np.arange(t.size), np.argmin(miss, axis=1)]))
    out: dict[str, np.ndarray] = {"time": t}
    for label, levels in (("bot", False), ("spl", True)):
        cfg = check_single_config(parse_toml(tracker_toml(levels, particles, seed),
                                             "known side")["tracker"], "known side")
        cfg.update(lr=False, side="starboard")
        lev = np.asarray(g["spl_db"], float)[keep] if levels else None
        xs, _, _, _ = track_bearings(t, z[:, None], own, cfg, lev)
        out[f"err_{label}_m"] = np.hypot(*(xs[:, :2] + pos - truth[:, :2]).T)
    return out


def integration_check(seed: int, workdir: str, snapshots: Sequence[int] = (60, 10),
                      duration: float | None = None) -> dict[int, dict[str, Any]]:
    """Diagnostic: one recording processed with the ``spl_tma`` chain and with copies of it
    integrating fewer 1-s snapshots, each scored by :func:`product_errors` (mean and
    standard deviation of the bearing and level errors per segment of :data:`SEGMENTS`), to
    see how the errors scale with the integration time.

    Returns
    -------
    dict
        snapshots → {segment → {``rows``, ``bearing_err_mean_deg``, ``bearing_err_std_deg``,
        ``level_err_mean_db``, ``level_err_std_db``}}.
    """
    os.makedirs(workdir, exist_ok=True)
    rec = os.path.join(workdir, f"rec_check_{seed}.h5")
    pipeline.simulate(str(data_path("scenarios", f"{SCENARIO}.toml")), rec, duration=duration,
                      seed=seed)
    text = data_path("chains", f"{CHAIN}.toml").read_text(encoding="utf-8")
    if "snapshots = 60" not in text:
        raise ValueError(f"chain {CHAIN}: no 'snapshots = 60' to change")
    out: dict[int, dict[str, Any]] = {}
    try:
        truth = recording_truth(rec)
        tab = load_default_table(TL_NAME)
        for n in snapshots:
            chain = os.path.join(workdir, f"chain_{n}.toml")
            Path(chain).write_text(text.replace("snapshots = 60", f"snapshots = {int(n)}"),
                                   encoding="utf-8")
            prod = os.path.join(workdir, f"products_check_{seed}_{n}.h5")
            pipeline.process(rec, chain, prod)
            e = product_errors(prod, truth, tab)
            tmin = e["time"] / 60.0
            out[int(n)] = {}
            for seg, (lo, hi) in SEGMENTS.items():
                sel = (tmin >= lo) & (tmin < hi)
                if sel.any():
                    b, lv = e["bearing_err_deg"][sel], e["level_err_db"][sel]
                    out[int(n)][seg] = {"rows": int(sel.sum()),
                                        "bearing_err_mean_deg": float(b.mean()),
                                        "bearing_err_std_deg": float(b.std()),
                                        "level_err_mean_db": float(lv.mean()),
                                        "level_err_std_db": float(lv.std())}
    finally:
        Path(rec).unlink(missing_ok=True)
    return out


def cached_seed(seed: int, workdir: str, duration: float | None = None,
                particles: int = 5000, log: Callable[[str], None] | None = None
                ) -> dict[str, Any]:
    """:func:`run_seed` with its result kept in ``workdir/seed_<seed>.npz`` (a run that stops
    resumes from the seeds done); a cache made with another ``duration`` or ``particles`` is
    recomputed."""
    path = Path(workdir) / f"seed_{seed}.npz"
    tag = np.array([np.nan if duration is None else duration, particles], float)
    if path.exists():
        with np.load(path) as z:
            if np.array_equal(z["tag"], tag, equal_nan=True):
                return {k: (int(z[k]) if k == "seed" else z[k]) for k in z.files if k != "tag"}
    out = run_seed(seed, workdir, duration, particles, log=log)
    np.savez(path, tag=tag, **out)
    return out
