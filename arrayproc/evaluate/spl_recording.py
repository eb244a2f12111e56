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
paper's σ's and with the σ's measured on the recordings.
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
           "summarise", "measurement_level", "cached_seed", "plot_rmse"]

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
    g = read_products(products_path)["bearings"]
    t = np.asarray(g["time"], float)
    snr = np.asarray(g["snr_db"], float)
    order = np.lexsort((-snr, t))
    keep = order[np.r_[True, t[order][1:] != t[order][:-1]]]
    t = t[keep]
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


def summarise(runs: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """RMSE against time over the seeds and the pooled product errors.

    Returns
    -------
    dict
        ``time_min`` (K,); ``rmse_{bot,spl}_m`` (K,) over the seeds
        (:func:`arrayproc.evaluate.accuracy.rmse`); ``level_err_{mean,std}_db`` and
        ``bearing_err_{bias,std}_deg`` pooled over rows and seeds, with the same for each
        seed's mean (``*_seed_std``: the spread of the per-seed biases) and the per-row
        95th percentiles of the absolute errors; the mean bearing error and its spread at
        each time; ``true_side`` of the first seed (+1 starboard, −1 port).
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
    lev = np.stack([r["level_err_db"] for r in runs])
    brg = np.stack([r["bearing_err_deg"] for r in runs])
    out.update(level_err_mean_db=float(lev.mean()), level_err_std_db=float(lev.std()),
               level_err_seed_mean_std_db=float(lev.mean(axis=1).std()),
               level_err_abs_p95_db=float(np.percentile(np.abs(lev), 95)),
               level_err_mean_by_time_db=lev.mean(axis=0).tolist(),
               bearing_err_bias_deg=float(brg.mean()), bearing_err_std_deg=float(brg.std()),
               bearing_err_seed_mean_std_deg=float(brg.mean(axis=1).std()),
               bearing_err_abs_p95_deg=float(np.percentile(np.abs(brg), 95)),
               bearing_err_mean_by_time_deg=brg.mean(axis=0).tolist(),
               bearing_err_std_by_time_deg=brg.std(axis=0).tolist(),
               snr_db_median=float(np.median(np.stack([r["snr_db"] for r in runs]))),
               true_side=np.stack([r["true_side"] for r in runs])[0].tolist())
    return out


def measurement_level(runs: int, particles: int, seed: int,
                      sigma_bearing_deg: float | None = None,
                      sigma_level_db: float | None = None, bearing_bias_deg: float = 0.0,
                      level_bias_db: float = 0.0) -> dict[str, Any]:
    """The paper's measurement-level Monte Carlo of the manoeuvring scenario (section 5.1,
    :func:`~arrayproc.evaluate.scenarios.spl_paper.rpf_monte_carlo`), with the data σ's of
    the paper (1.5°, 4 dB) or the given ones, plus constant biases if given (added to every
    bearing and level); the filter keeps the paper's σ_θ and σ_l.

    Returns
    -------
    dict
        ``time_min`` (K,), ``rmse_{bot,spl}_m`` (K,), ``sigma_bearing_deg``,
        ``sigma_level_db`` (of the data).
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
    data.bearings_deg = (data.bearings_deg + bearing_bias_deg) % 360.0
    data.levels_db = data.levels_db + level_bias_db
    res = rpf_monte_carlo(sc, data, tab, particles, seed)
    return {"runs": runs, "particles": particles, "seed": seed,
            "sigma_bearing_deg": float(sc.sigma_bearing_deg if sigma_bearing_deg is None
                                       else sigma_bearing_deg),
            "sigma_level_db": float(sc.sigma_level_data_db),
            "bearing_bias_deg": float(bearing_bias_deg), "level_bias_db": float(level_bias_db),
            "time_min": (sc.times / 60.0).tolist(), "rmse_bot_m": res["rmse_bot"].tolist(),
            "rmse_spl_m": res["rmse_spl"].tolist()}


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


def plot_rmse(res: dict[str, Any], path: str) -> None:
    """Position RMSE against time: the recordings' tracks (bearings only, with levels), the
    measurement-level Monte Carlo with the paper's σ's and with the measured ones, and the
    paper's fig. 3 values (:data:`~arrayproc.evaluate.scenarios.spl_paper.PAPER`)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from arrayproc.evaluate.scenarios.spl_paper import PAPER

    fig, ax = plt.subplots(figsize=(8.0, 5.0))
    n = len(res["seeds"])
    for label, col in (("bot", "tab:blue"), ("spl", "tab:red")):
        name = "BOT" if label == "bot" else "BOT+SPL"
        ax.plot(res["time_min"], res[f"rmse_{label}_m"], "-o", color=col, ms=3,
                label=f"recording {name} ({n} seeds)")
        for key, ls, what in (("measurement_level_paper", "--", "paper σ"),
                              ("measurement_level_measured", ":", "measured σ")):
            mc = res.get(key)
            if mc:
                ax.plot(mc["time_min"], mc[f"rmse_{label}_m"], ls, color=col,
                        label=f"measurement-level {name}, {what} ({mc['runs']} runs)")
        pts = list(PAPER["manoeuvring"].values())
        ax.plot([p[0] for p in pts], [p[1 if label == "bot" else 2] for p in pts], "*",
                color=col, ms=12, mec="k", label=f"paper fig. 3 {name}")
    ax.axvspan(13.0, 17.0, color="0.9", zorder=0, label="observer turn")
    ax.set_yscale("log")
    ax.set_xlabel("time (min)")
    ax.set_ylabel("position RMSE (m)")
    ax.set_title("SPL paper, manoeuvring observer: RPF from recordings vs measurement level")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="lower left")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
