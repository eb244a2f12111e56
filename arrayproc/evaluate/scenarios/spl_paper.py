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

from dataclasses import dataclass

import numpy as np

from arrayproc.acoustics.source_level import ROSS_SURFACE_SHIP, SourceLevelModel, received_level
from arrayproc.acoustics.tl.table import TLTable, load_default_table
from arrayproc.errors import ConfigError
from arrayproc.geo.angles import true_bearing, wrap_2pi
from arrayproc.geo.kinematics import KNOT, Trajectory, course_to_velocity
from arrayproc.track.crlb import bearings_only_crlb, polar_prior_covariance

__all__ = ["SPLScenario", "SCENARIOS", "get_scenario", "ScenarioData"]


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

