"""Regularized particle filter for bearings (+ received levels) TMA (SPL paper section 4).

Musso, Oudjane & Le Gland (2001) as used by Iglésis & de Montella (2024): prediction with the
constant-velocity model (eqs. (4)-(6), (17)), weights from the bearing and level likelihoods
(eqs. (18)-(19), (31)-(33)), regularization-resampling when N_eff (eq. (20)) < N_thr·N with
the Epanechnikov kernel and the MISE-optimal bandwidth (eqs. (21)-(28)), estimate and
covariance after that step (eqs. (29)-(30)). Bearings-only tracking is the same filter with
the level term switched off. The per-particle work is in
:mod:`arrayproc.track.filters._pf_kernels`: :class:`RegularizedParticleFilter` runs many Monte
Carlo runs in one fused kernel (bearing and level terms inlined from the measurement models'
kernels); :class:`RPF` is the step-by-step filter for any measurement model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from arrayproc.acoustics.source_level import ROSS_SURFACE_SHIP, SourceLevelModel
from arrayproc.acoustics.tl.table import TLTable
from arrayproc.errors import ConfigError
from arrayproc.geo.kinematics import KNOT
from arrayproc.track.base import Param
from arrayproc.track.filters import _pf_kernels as kpf
from arrayproc.track.filters.base import Filter, FilterDivergence
from arrayproc.track.models.base import MeasurementModel, MotionModel
from arrayproc.track.state import Context, ParticleState

__all__ = ["RPFConfig", "RPFResult", "RegularizedParticleFilter", "RPF", "run_seeds"]


@dataclass
class RPFConfig:
    """Filter settings; defaults are the SPL paper's section 5 values."""

    n_particles: int = 5000
    n_thr: float = 1.0 / 3.0                 # resample when N_eff < n_thr · N
    sigma_a: float = 1.5e-3                  # m/s², process noise std (eq. (6))
    sigma_bearing_deg: float = 1.5
    sigma_level_db: float = 10.0             # filter's σ_l (data: 4 dB in the paper)
    use_levels: bool = True                  # False: bearings-only tracking
    resampling: str = "systematic"           # or "multinomial" (the paper's)
    bandwidth_scale: float = 1.0             # × MISE-optimal h (eq. (27)); 1 in the paper
    range_mean_m: float = 10e3               # prior (Ristic et al. 2003 ch. 6.4.1.1)
    range_std_m: float = 2e3
    speed_mean: float = 3 * KNOT
    speed_std: float = 2 * KNOT
    course_offset_deg: float = 180.0         # prior course = first bearing + offset
    course_std_deg: float = float(np.rad2deg(np.pi / np.sqrt(12.0)))
    course_prior: str = "normal"             # Ristic ch. 6.4.1.1; "uniform": U(±√3·σ)
    min_range_m: float = 100.0
    max_speed_kn: float = 0.0                # > 0: zero weight above this speed (not in
    #                                          the paper; docs/validation.md, Tracking II)
    source_level: SourceLevelModel = field(default_factory=lambda: ROSS_SURFACE_SHIP)
    tl_table: TLTable | None = None
    src_depth_m: float = 5.0
    rcv_depth_m: float = 300.0

    def validate(self) -> None:
        if self.n_particles < 2:
            raise ConfigError("rpf: n_particles must be >= 2")
        if not 0.0 < self.n_thr <= 1.0:
            raise ConfigError("rpf: n_thr must be in (0, 1]")
        if self.resampling not in ("systematic", "multinomial"):
            raise ConfigError("rpf: resampling must be 'systematic' or 'multinomial'")
        if self.course_prior not in ("uniform", "normal"):
            raise ConfigError("rpf: course_prior must be 'uniform' or 'normal'")
        if not self.max_speed_kn >= 0:
            raise ConfigError("rpf: max_speed_kn must be >= 0 (0: no limit)")
        if self.use_levels and self.tl_table is None:
            raise ConfigError("rpf: use_levels needs a tl_table")
        for name in ("sigma_bearing_deg", "sigma_level_db", "range_std_m", "bandwidth_scale"):
            if getattr(self, name) <= 0:
                raise ConfigError(f"rpf: {name} must be > 0")


@dataclass
class RPFResult:
    """Estimates (…, K, 4) [x, y, vx, vy], covariances (…, K, 4, 4), resampling flags."""

    est: np.ndarray
    cov: np.ndarray
    resampled: np.ndarray


def run_seeds(seed: int, n_runs: int, tag: int = 0) -> np.ndarray:
    """Per-run uint64 seeds of the filter's random stream, derived from (seed, run, tag)."""
    return np.array([np.random.SeedSequence([seed, r, tag]).generate_state(1, np.uint64)[0]
                     for r in range(n_runs)], dtype=np.uint64)


class RegularizedParticleFilter:
    """RPF of SPL paper section 4; see :class:`RPFConfig` for the settings."""

    def __init__(self, config: RPFConfig | None = None) -> None:
        self.config = config or RPFConfig()
        self.config.validate()
        c = self.config
        if c.tl_table is not None:
            self._tl = c.tl_table.range_profile(c.src_depth_m, c.rcv_depth_m)
        else:
            self._tl = (0.0, 1.0, np.zeros(2))

    def _prior(self) -> np.ndarray:
        c = self.config
        return np.array([c.range_mean_m, c.range_std_m, c.speed_mean, c.speed_std,
                         np.deg2rad(c.course_offset_deg), np.deg2rad(c.course_std_deg),
                         c.min_range_m, 1.0 if c.course_prior == "uniform" else 0.0,
                         c.max_speed_kn * KNOT])

    def run_many(self, times: np.ndarray, observer_pos: np.ndarray, bearings_deg: np.ndarray,
                 levels_db: np.ndarray | None = None, seeds: np.ndarray | None = None,
                 seed: int = 0) -> RPFResult:
        """Run the filter on R independent measurement sets at once (parallel over runs).

        ``bearings_deg`` and ``levels_db`` are (R, K) (true bearings, deg; levels dB re 1 µPa),
        ``times`` (K,) s, ``observer_pos`` (K, 2) m. ``seeds`` (R,) uint64, else derived from
        ``seed``. The bearing at k = 0 initialises the prior (Ristic et al. 2003 ch. 6.4.1.1).
        """
        c = self.config
        th = np.ascontiguousarray(np.deg2rad(np.atleast_2d(np.asarray(bearings_deg, float))))
        n_runs, k_n = th.shape
        t = np.ascontiguousarray(np.asarray(times, float).reshape(k_n))
        obs = np.ascontiguousarray(np.asarray(observer_pos, float).reshape(k_n, 2))
        if levels_db is None:
            if c.use_levels:
                raise ConfigError("rpf: use_levels is set but no levels were given")
            lv = np.zeros_like(th)
        else:
            lv = np.ascontiguousarray(np.atleast_2d(np.asarray(levels_db, float)))
            if lv.shape != th.shape:
                raise ConfigError("rpf: levels and bearings must have the same shape")
        if not (np.all(np.isfinite(th)) and np.all(np.isfinite(lv)) and np.all(np.diff(t) > 0)):
            raise ConfigError("rpf: measurements must be finite and times increasing")
        sd = run_seeds(seed, n_runs) if seeds is None else np.asarray(seeds, np.uint64)
        est = np.empty((n_runs, k_n, 4))
        cov = np.empty((n_runs, k_n, 4, 4))
        rs = np.zeros((n_runs, k_n), dtype=np.bool_)
        r0, dr, tl = self._tl
        kpf.rpf_monte_carlo(th, lv, False, bool(c.use_levels), t, obs, sd, int(c.n_particles),
                            float(c.n_thr), float(c.sigma_a),
                            float(np.deg2rad(c.sigma_bearing_deg)), float(c.sigma_level_db),
                            self._prior(), c.source_level.as_array(), r0, dr, tl,
                            0 if c.resampling == "systematic" else 1,
                            float(c.bandwidth_scale), est, cov, rs)
        return RPFResult(est, cov, rs)

    def run(self, times: np.ndarray, observer_pos: np.ndarray, bearings_deg: np.ndarray,
            levels_db: np.ndarray | None = None, seed: int = 0) -> RPFResult:
        """Run the filter on one measurement sequence; results (K, 4), (K, 4, 4), (K,)."""
        res = self.run_many(times, observer_pos, np.asarray(bearings_deg)[None],
                            None if levels_db is None else np.asarray(levels_db)[None],
                            seed=seed)
        return RPFResult(res.est[0], res.cov[0], res.resampled[0])


def _pos(v: float) -> str | None:
    return None if v > 0 else "must be > 0"


class RPF(Filter):
    """Step-by-step regularized particle filter with the filter interface of
    :mod:`arrayproc.track.filters` (``initialize``, ``predict``, ``update`` → (state,
    log-likelihood)), for any measurement model with a per-particle log-likelihood
    (:meth:`~arrayproc.track.models.base.MeasurementModel.loglik_particles`): bearings,
    bearings + levels (SPL paper eqs. (31)-(33)), ... Constant-velocity motion only (SPL paper
    eqs. (4)-(6)).

    ``initialize`` draws the particles from N(x0, P0) (the runner's linearised polar prior)
    with the cloud's own random stream (seeded by ``seed``). The process noise is ``sigma_a``
    (m/s²) if given, else σ_a² = q1 / T from the motion model's white-noise intensity (the same
    velocity variance per step). ``update`` returns log p(z_k | z_1..k−1) ≈ log Σ w_i p(z_k | x_i).
    ``max_speed_kn`` > 0 gives zero weight to particles faster than that (absolute speed).
    """

    name = "rpf"
    params = {
        "n_particles": Param("int", 5000, "particles", check=lambda v: None if v >= 2 else
                             "must be >= 2"),
        "n_thr": Param("float", 1.0 / 3.0, "resample when N_eff < n_thr·N",
                       check=lambda v: None if 0 < v <= 1 else "must be in (0, 1]"),
        "sigma_a": Param("float", None, "process noise std, m/s² (default from q1)"),
        "resampling": Param("str", "systematic", "resampling scheme",
                            choices=("systematic", "multinomial")),
        "bandwidth_scale": Param("float", 1.0, "× MISE-optimal bandwidth (eq. (27))",
                                 check=_pos),
        "seed": Param("int", 0, "seed of the particles' random stream"),
        "max_speed_kn": Param("float", 0.0, "speed gate, kn (0: none)",
                              check=lambda v: None if v >= 0 else "must be >= 0 (0: no limit)"),
    }

    def _setup(self) -> None:
        self.method = 0 if self.resampling == "systematic" else 1
        self.h = float(self.bandwidth_scale) * kpf.bandwidth(self.n_particles)
        self.v_max = float(self.max_speed_kn) * KNOT

    def initialize(self, x0: np.ndarray, P0: np.ndarray, t: float = 0.0) -> ParticleState:
        """Particles drawn from N(x0, P0) (4-state)."""
        n = self.n_particles
        x0 = np.asarray(x0, float).reshape(-1)
        if x0.size != 4:
            raise ConfigError("tracker: the rpf filter supports the cv model only")
        P0 = np.asarray(P0, float).reshape(4, 4)
        rng = np.array([run_seeds(int(self.seed), 1, tag=3)[0]], dtype=np.uint64)
        d = np.linalg.cholesky(P0)
        z = kpf.normal_block(rng, 2 * n).reshape(n, 4)
        return ParticleState(x0 + z @ d.T, np.ones(n), float(n), rng, x0.copy(), P0.copy(), t)

    def predict(self, state: ParticleState, motion_model: MotionModel, dt: float,
                ctx: Context) -> ParticleState:
        """Move every particle with the CV model and white accelerations (eqs. (4)-(6), (17)).

        Parameters
        ----------
        state : ParticleState
        motion_model : MotionModel
            :class:`~arrayproc.track.models.ConstantVelocity` (its ``q1`` sets σ_a when the
            filter's ``sigma_a`` is unset).
        dt : float
            Time step, s.
        ctx : Context
            Observer states at the previous and new times.

        Returns
        -------
        ParticleState
        """
        if not (motion_model.linear and motion_model.ndim == 4):
            raise ConfigError("tracker: the rpf filter supports the cv model only")
        sa = self.sigma_a if self.sigma_a is not None else (
            math.sqrt(motion_model.q1 / dt) if dt > 0 else 0.0)
        absolute = state.particles + ctx.own_prev  # eq. (4): x + x^o, then F, then − x^o'
        rng = state.rng.copy()
        kpf.propagate_cv(absolute, rng, float(dt), float(sa))
        return ParticleState(absolute - ctx.own, state.weights.copy(), state.weight_sum, rng,
                             state.x, state.P, state.t + dt, state.n_resampled)

    def update(self, state: ParticleState, z, measurement_model: MeasurementModel,
               ctx: Context) -> tuple[ParticleState, float]:
        """Weight by the measurement, regularize-resample if needed (eqs. (18)-(30)).

        Parameters
        ----------
        state : ParticleState
            Predicted cloud.
        z : array_like
            Measurement in the model's units.
        measurement_model : MeasurementModel
        ctx : Context

        Returns
        -------
        ParticleState
        float
            log p(z | past measurements).
        """
        n = self.n_particles
        parts = state.particles.copy()
        w = state.weights.copy()
        rng = state.rng.copy()
        ll = np.empty(n)
        measurement_model.loglik_particles(parts, np.asarray(z, float).reshape(-1), ctx, ll)
        mean = np.empty(4)
        pcov = np.empty((4, 4))
        s, logev, done = kpf.rpf_correct(parts, w, np.empty(n), state.weight_sum, ll, rng,
                                         self.n_thr, self.method, self.h,
                                         np.empty(n, np.int64), np.empty((n, 4)), mean, pcov,
                                         np.empty((4, 4)), self.v_max, float(ctx.own[2]),
                                         float(ctx.own[3]))
        if not (np.all(np.isfinite(mean)) and np.all(np.isfinite(pcov))):
            raise FilterDivergence("rpf: non-finite state")
        out = ParticleState(parts, w, s, rng, mean, pcov, state.t,
                            state.n_resampled + int(done))
        return out, float(logev - measurement_model.loglik_norm(ctx))
