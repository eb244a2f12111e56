"""The three scenarios of the SPL paper's section 5 (after Ristic et al. 2003 ch. 6).

Common: observer at [0, 0] m, depth 300 m; target at [5000, 800] m, depth 5 m, 5 kn on course
−140°; one bearing (σ_θ = 1.5°) and one level (σ_l = 4 dB in the data) every 60 s; source level
eq. (12); TL from the appendix environment (bundled bellhopcxx incoherent table).

* ``manoeuvring`` — 30 min; observer 5 kn on 140°, turning at 30°/min between 13 and 17 min to
  20° (section 5.1).
* ``parallel`` — 150 min; observer 5 kn on −140°, parallel to the target (section 5.2).
* ``static`` — 150 min; observer stays at [0, 0] (section 5.3).

The truth is a constant-velocity track (the paper: "maintains a constant speed ... and a
steady course"); the filter's process noise σ_a = 1.5e-3 m/s² is a modelling allowance.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from arrayproc.acoustics.source_level import ROSS_SURFACE_SHIP, SourceLevelModel, received_level
from arrayproc.acoustics.tl.table import TLTable, load_default_table
from arrayproc.errors import ConfigError
from arrayproc.evaluate.accuracy import rmse
from arrayproc.geo.angles import true_bearing, wrap_2pi
from arrayproc.geo.kinematics import KNOT, Trajectory, course_to_velocity
from arrayproc.track.crlb import bearings_only_crlb, polar_prior_covariance
from arrayproc.track.filters.particle import RegularizedParticleFilter, RPFConfig, run_seeds

__all__ = ["SPLScenario", "SCENARIOS", "get_scenario", "ScenarioData", "PAPER",
           "rpf_monte_carlo", "compare_with_paper", "parallel_grid_posterior"]


@dataclass
class ScenarioData:
    """Simulated measurements for R runs: bearings (R, K) deg, levels (R, K) dB re 1 µPa."""

    times: np.ndarray
    observer_pos: np.ndarray
    truth: np.ndarray
    bearings_deg: np.ndarray
    levels_db: np.ndarray


@dataclass
class SPLScenario:
    name: str
    duration_s: float
    observer: Trajectory
    target_start: tuple = (5000.0, 800.0)
    target_course_deg: float = -140.0
    target_speed: float = 5 * KNOT
    target_depth_m: float = 5.0
    observer_depth_m: float = 300.0
    dt: float = 60.0
    sigma_bearing_deg: float = 1.5
    sigma_level_data_db: float = 4.0
    sigma_level_filter_db: float = 10.0
    range_prior_m: tuple = (10e3, 2e3)
    speed_prior: tuple = (3 * KNOT, 2 * KNOT)
    course_std_rad: float = float(np.pi / np.sqrt(12.0))
    source_level: SourceLevelModel = ROSS_SURFACE_SHIP

    @property
    def times(self) -> np.ndarray:
        """Measurement times 0, 60, …, duration (s)."""
        return np.arange(0.0, self.duration_s + 0.5 * self.dt, self.dt)

    def target_x0(self) -> np.ndarray:
        v = course_to_velocity(self.target_course_deg, self.target_speed)
        return np.array([*self.target_start, *v])

    def truth(self, times: np.ndarray | None = None) -> np.ndarray:
        """True target state (K, 4), constant velocity."""
        t = self.times if times is None else np.asarray(times, float)
        x0 = self.target_x0()
        out = np.empty((t.size, 4))
        out[:, :2] = x0[:2] + t[:, None] * x0[2:]
        out[:, 2:] = x0[2:]
        return out

    def observer_pos(self, times: np.ndarray | None = None) -> np.ndarray:
        t = self.times if times is None else np.asarray(times, float)
        return self.observer.state(t)[0]

    def simulate(self, n_runs: int, seed: int, tl: TLTable | None = None,
                 truth_sigma_a: float = 0.0) -> ScenarioData:
        """Bearings (eq. (8)) and levels (eq. (15)) for ``n_runs`` runs; run r draws from
        ``numpy.random.default_rng([seed, r])``. With ``truth_sigma_a`` > 0 (m/s²) every run has
        its own true track, driven by white accelerations of that standard deviation held over
        each measurement interval (eqs. (4)-(6)); ``truth`` is then (R, K, 4)."""
        if n_runs < 1:
            raise ConfigError("scenario: n_runs must be >= 1")
        tl = tl or load_default_table()
        t = self.times
        obs = self.observer_pos(t)
        sb = np.deg2rad(self.sigma_bearing_deg)
        bear = np.empty((n_runs, t.size))
        lev = np.empty((n_runs, t.size))
        truth = self.truth(t)
        runs_truth = np.empty((n_runs, t.size, 4)) if truth_sigma_a > 0 else None

        def tl_fn(r):
            return tl(r, self.target_depth_m, self.observer_depth_m)

        x = truth
        for r in range(n_runs):
            rng = np.random.default_rng([seed, r])
            if runs_truth is not None:
                x = runs_truth[r]
                x[0] = self.target_x0()
                for k in range(1, t.size):
                    dt = t[k] - t[k - 1]
                    a = truth_sigma_a * rng.standard_normal(2)
                    x[k, :2] = x[k - 1, :2] + dt * x[k - 1, 2:] + 0.5 * dt * dt * a
                    x[k, 2:] = x[k - 1, 2:] + dt * a
            if r == 0 or runs_truth is not None:
                d = x[:, :2] - obs
                b_true = true_bearing(d[:, 0], d[:, 1])
                h_l = received_level(x, obs, tl_fn, self.source_level)
            bear[r] = np.rad2deg(wrap_2pi(b_true + sb * rng.standard_normal(t.size)))
            lev[r] = h_l + self.sigma_level_data_db * rng.standard_normal(t.size)
        return ScenarioData(t, obs, truth if runs_truth is None else runs_truth, bear, lev)

    def prior_covariance(self) -> np.ndarray:
        """Covariance of the filter's initial distribution (linearised, at the prior means),
        for the CRLB's initial information J₁ = P₁⁻¹ (Ristic et al. 2003 ch. 6.3)."""
        d = self.truth()[0, :2] - self.observer_pos()[0]
        b0 = float(np.arctan2(d[0], d[1]))
        return polar_prior_covariance(b0, self.range_prior_m[0],
                                      np.deg2rad(self.sigma_bearing_deg), self.range_prior_m[1],
                                      self.speed_prior[0], b0 + np.pi, self.speed_prior[1],
                                      self.course_std_rad)

    def crlb(self, with_prior: bool = True) -> np.ndarray:
        """Bearings-only CRLB (K, 4, 4), zero process noise (Ristic et al. 2003 ch. 4.3.3)."""
        prior = np.linalg.inv(self.prior_covariance()) if with_prior else None
        return bearings_only_crlb(self.target_x0(), self.times, self.observer_pos(),
                                  np.deg2rad(self.sigma_bearing_deg), prior)

    def position_error(self, est: np.ndarray, truth: np.ndarray | None = None) -> np.ndarray:
        """Position error norm (…, K) m of estimates (…, K, 4) against ``truth`` (K, 4) or
        (R, K, 4) (default: the deterministic track)."""
        truth = self.truth() if truth is None else truth
        return np.linalg.norm(est[..., :2] - truth[..., :2], axis=-1)


def _manoeuvring() -> SPLScenario:
    obs = Trajectory.from_legs([0.0, 0.0], [
        {"course": 140.0, "speed": 5 * KNOT, "duration": 780.0},
        {"course": 20.0, "speed": 5 * KNOT, "duration": 1020.0, "turn_rate": 0.5},
    ])
    return SPLScenario("manoeuvring", 1800.0, obs)


def _parallel() -> SPLScenario:
    obs = Trajectory.from_legs([0.0, 0.0], [{"course": -140.0, "speed": 5 * KNOT,
                                             "duration": 9000.0}])
    return SPLScenario("parallel", 9000.0, obs)


def _static() -> SPLScenario:
    return SPLScenario("static", 9000.0, Trajectory.static((0.0, 0.0)))


SCENARIOS = {"manoeuvring": _manoeuvring, "parallel": _parallel, "static": _static}


def get_scenario(name: str) -> SPLScenario:
    """One of ``manoeuvring``, ``parallel``, ``static``."""
    try:
        return SCENARIOS[name]()
    except KeyError:
        raise ConfigError(f"unknown scenario {name!r}; choose from {sorted(SCENARIOS)}") from None


# -- the reproduction: RPF Monte Carlo (section 4) and the paper's numbers -------------------
#: Published values: (time_min, BOT m, BOT+SPL m); None where the paper gives no number.
PAPER = {
    "manoeuvring": {"min near 24 min": (24.0, 155.0, 85.0), "final (30 min)": (30.0, 228.58,
                                                                                146.17)},
    "static": {"36 min": (36.0, 2857.0, 344.0), "63 min": (63.0, 4338.0, 203.0),
               "final (150 min)": (150.0, 13657.0, 1532.0)},
    "parallel": {},
}



def rpf_monte_carlo(sc: SPLScenario, data: ScenarioData, tab: TLTable, particles: int,
                    seed: int, resampling: str = "systematic", bandwidth_scale: float = 1.0,
                    sigma_a: float = 1.5e-3, course_prior: str = "normal",
                    max_speed_kn: float = 0.0, client: Any = None, chunk: int = 10) -> dict:
    """The same simulated runs through the regularised particle filter twice, bearings only
    (``bot``) and bearings + levels (``spl``), each run on its own seed (the same numbers on a
    Dask ``client`` as here).

    Parameters
    ----------
    sc, data, tab
        Scenario, its :meth:`SPLScenario.simulate` output and the TL table.
    particles, seed, resampling, bandwidth_scale, sigma_a, course_prior, max_speed_kn
        Filter settings (:class:`arrayproc.track.filters.particle.RPFConfig`); ``seed`` roots
        the per-run filter seeds.
    client : distributed.Client, optional
        Where the runs go, in slices of ``chunk``.

    Returns
    -------
    dict
        ``rmse_{bot,spl}`` (K,) m over the runs (:func:`arrayproc.evaluate.accuracy.rmse` of
        the position error), ``wall_s_*``, ``resampling_fraction_*``,
        ``median_final_error_*_m``.
    """
    from arrayproc.evaluate.distributed import rpf_slice, spread_slices
    out: dict = {}
    for label, use in (("bot", False), ("spl", True)):
        cfg = RPFConfig(n_particles=particles, use_levels=use, tl_table=tab,
                        resampling=resampling, bandwidth_scale=bandwidth_scale,
                        sigma_a=sigma_a, sigma_bearing_deg=sc.sigma_bearing_deg,
                        sigma_level_db=sc.sigma_level_filter_db,
                        course_prior=course_prior, max_speed_kn=max_speed_kn)
        f = RegularizedParticleFilter(cfg)
        f.run_many(data.times[:3], data.observer_pos[:3], data.bearings_deg[:1, :3],
                   data.levels_db[:1, :3] if use else None)          # compile outside timing
        t0 = time.perf_counter()
        seeds = run_seeds(seed, data.bearings_deg.shape[0], tag=1 + int(use))
        if client is not None:
            parts = spread_slices(rpf_slice, data.bearings_deg.shape[0], client, chunk,
                                  config=cfg, times=data.times,
                                  observer_pos=data.observer_pos,
                                  bearings_deg=data.bearings_deg,
                                  levels_db=data.levels_db if use else None, seeds=seeds)
            est = np.concatenate([p[0] for p in parts])
            resampled = np.concatenate([p[1] for p in parts])
        else:
            res = f.run_many(data.times, data.observer_pos, data.bearings_deg,
                             data.levels_db if use else None, seeds=seeds)
            est, resampled = res.est, res.resampled
        out[f"wall_s_{label}"] = time.perf_counter() - t0
        err = sc.position_error(est, data.truth)
        out[f"rmse_{label}"] = rmse(err)
        out[f"resampling_fraction_{label}"] = float(resampled.mean())
        out[f"median_final_error_{label}_m"] = float(np.median(err[:, -1]))
    return out


def compare_with_paper(name: str, tmin: np.ndarray, rm: dict[str, np.ndarray],
                       crlb: np.ndarray) -> tuple[list[dict], dict]:
    """Our RMSE next to the paper's numbers (:data:`PAPER`) and the scenario's own figures:
    the minimum after the turn (manoeuvring), the minimum and the CRLB at 150 min (static),
    when SPL falls below the bearings-only CRLB and the final BOT/SPL ratio (parallel).

    Parameters
    ----------
    name : str
        Scenario name.
    tmin : (K,) array
        Times, min.
    rm : dict
        ``{"bot": (K,), "spl": (K,)}`` RMSE, m.
    crlb : (K,) array
        Bearings-only position RMSE bound, m.

    Returns
    -------
    (list of dict, dict)
        Table rows (``what``, ``time_min``, ``paper_*_m``, ``ours_*_m``) and the extra
        figures.
    """
    rows, extra = [], {}
    for what, (t, pb, ps) in PAPER[name].items():
        i = int(np.argmin(np.abs(tmin - t)))
        rows.append({"what": what, "time_min": t, "paper_bot_m": pb, "ours_bot_m": rm["bot"][i],
                     "paper_spl_m": ps, "ours_spl_m": rm["spl"][i]})
    if name in ("manoeuvring", "static"):
        after = tmin >= 17.0 if name == "manoeuvring" else np.ones(tmin.size, bool)
        for label in ("bot", "spl"):
            j = int(np.argmin(np.where(after, rm[label], np.inf)))
            extra[f"min_rmse_{label}_m"] = float(rm[label][j])
            extra[f"min_rmse_{label}_time_min"] = float(tmin[j])
    if name == "static":
        rows.append({"what": "CRLB at 150 min (paper: 313.88 % above RMSE+SPL)",
                     "time_min": 150.0, "paper_bot_m": 1532.0 * 4.1388,
                     "ours_bot_m": float(crlb[-1]), "paper_spl_m": None, "ours_spl_m": None})
    if name == "parallel":
        below = np.where(rm["spl"] < crlb)[0]
        extra["spl_below_crlb_from_min"] = float(tmin[below[0]]) if below.size else None
        extra["final_ratio_bot_over_spl"] = float(rm["bot"][-1] / rm["spl"][-1])
        rows.append({"what": "final BOT/SPL ratio (paper 5.77)", "time_min": 150.0,
                     "paper_bot_m": 5.7743, "ours_bot_m": extra["final_ratio_bot_over_spl"],
                     "paper_spl_m": None, "ours_spl_m": None})
    return rows, extra


def parallel_grid_posterior(sc: SPLScenario, data: ScenarioData, tab: TLTable,
                            n_runs: int) -> dict:
    """Parallel scenario: the exact posterior on the constant-bearing family (the BOT
    ambiguity: relative position r(t) = (r0 + ṙ t)·u, target velocity v_obs + ṙ u, zero
    process noise), from the paper's prior and the level likelihood with the filter's σ_l,
    on a grid of (r0, ṙ). Returns the RMSE of its posterior-mean range at each time — what an
    ideal filter could reach without regularization noise (a diagnostic, not the paper's
    algorithm)."""
    sl = sc.source_level
    t = data.times
    u = data.truth[0, :2] - data.observer_pos[0]
    u = u / np.hypot(*u)
    v_obs = sc.observer.state(t)[1][0]
    c0 = np.arctan2(*u) + np.pi
    r0 = np.arange(1000.0, 40001.0, 250.0)
    rdot = np.arange(-3.0, 10.0, 0.05)
    true_r = np.hypot(*(data.truth[:, :2] - data.observer_pos).T)
    sq = np.zeros(t.size)
    for run in range(n_runs):
        lp = np.full((r0.size, rdot.size), -np.inf)
        for j, rd in enumerate(rdot):
            v = v_obs + rd * u
            spd, crs = np.hypot(*v), np.arctan2(v[0], v[1])
            r = r0[:, None] + rd * t[None, :]
            pred = sl(spd) - tab(np.maximum(r, 1.0), sc.target_depth_m, sc.observer_depth_m)
            ll = -np.sum((data.levels_db[run] - pred) ** 2, axis=1) / (
                2 * sc.sigma_level_filter_db**2)
            prior = (-(r0 - sc.range_prior_m[0]) ** 2 / (2 * sc.range_prior_m[1] ** 2)
                     - (spd - sc.speed_prior[0]) ** 2 / (2 * sc.speed_prior[1] ** 2)
                     - np.angle(np.exp(1j * (crs - c0))) ** 2 / (2 * sc.course_std_rad**2))
            lp[:, j] = np.where(r.min(axis=1) > 100.0, ll + prior, -np.inf)
        p = np.exp(lp - lp.max())
        p /= p.sum()
        for k in range(t.size):
            rk = r0[:, None] + rdot[None, :] * t[k]
            sq[k] += ((p * rk).sum() - true_r[k]) ** 2
    return {"grid_runs": n_runs, "grid_rmse_range_m": np.sqrt(sq / n_runs).tolist()}
