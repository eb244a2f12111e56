"""Regularized particle filter for bearings (+ received levels) TMA (SPL paper section 4).

Musso, Oudjane & Le Gland (2001) as used by Iglésis & de Montella (2024): prediction with the
constant-velocity model (eqs. (4)-(6), (17)), weights from the bearing and level likelihoods
(eqs. (18)-(19), (31)-(33)), regularization-resampling when N_eff (eq. (20)) < N_thr·N with
the Epanechnikov kernel and the MISE-optimal bandwidth (eqs. (21)-(28)), estimate and
covariance after that step (eqs. (29)-(30)). Bearings-only tracking is the same filter with
the level term switched off. The per-particle work is in :mod:`arrayproc.track._pf_kernels`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from arrayproc.acoustics.source_level import ROSS_SURFACE_SHIP, SourceLevelModel
from arrayproc.acoustics.tl.table import TLTable
from arrayproc.errors import ConfigError
from arrayproc.geo.kinematics import KNOT
from arrayproc.track import _pf_kernels as kpf

__all__ = ["RPFConfig", "RPFResult", "RegularizedParticleFilter", "RPFTracker", "run_seeds"]


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


class RPFTracker:
    """Step-by-step bearings-only RPF with the interface of :mod:`arrayproc.track.filters`
    (``initialize``, ``predict``, ``update`` → log-likelihood, attributes ``x``, ``P`` — the
    relative state [x, y, ẋ, ẏ] and covariance), so that ``arrayproc track`` and the L-R
    resolver can use it (``filter = "rpf"``). CV model only.

    ``initialize`` draws the particles from N(x0, P0) (the runner's linearised polar prior).
    The process noise is ``sigma_a`` (m/s²) if given, else σ_a² = q1 / T from the model's
    white-noise intensity (the same velocity variance per step). ``update`` returns
    log p(z_k | z_1..k−1) ≈ log Σ w_i p(z_k | x_i).

    Levels (SPL paper eqs. (15)-(16), (31)-(33)): with ``tl_table`` (a bundled table name in
    ``data/tl`` or a path to a table file), ``update(bearing_deg, level_db)`` also weights by
    the received level (dB re 1 µPa) with ``sigma_level_db``, source level eq. (12)
    (``source_level`` = (sl0, slope, v_ref)) and TL at (``src_depth_m``, ``rcv_depth_m``).
    ``max_speed_kn`` > 0 gives zero weight to particles faster than that (absolute speed).
    """

    name = "rpf"

    uses_levels = True  # update(bearing_deg, level_db): ``tracker.level`` may feed it

    def __init__(self, model, sigma_deg: float = 1.5, n_particles: int = 5000,
                 n_thr: float = 1.0 / 3.0, sigma_a: float | None = None,
                 resampling: str = "systematic", bandwidth_scale: float = 1.0,
                 seed: int = 0, tl_table: str | None = None, src_depth_m: float = 5.0,
                 rcv_depth_m: float = 300.0, sigma_level_db: float = 10.0,
                 source_level: tuple = (170.0, 53.0, 5.14), max_speed_kn: float = 0.0) -> None:
        if getattr(model, "dim", 4) != 4:
            raise ConfigError("tracker: the rpf filter supports the cv model only")
        if not sigma_deg > 0 or n_particles < 2 or not 0 < n_thr <= 1:
            raise ConfigError("tracker: rpf needs sigma_bearing_deg > 0, n_particles >= 2, "
                              "0 < n_thr <= 1")
        if resampling not in ("systematic", "multinomial"):
            raise ConfigError("tracker: rpf resampling must be 'systematic' or 'multinomial'")
        self.model = model
        self.sigma = math.radians(float(sigma_deg))
        self.sigma_level = float(sigma_level_db)
        self.sl_par = np.asarray(source_level, float).reshape(3)
        self.tl = (0.0, 1.0, np.zeros(2))
        self.has_tl = tl_table is not None
        if self.has_tl:
            from arrayproc.acoustics.tl.table import default_table_path

            path = tl_table if ("/" in tl_table or tl_table.endswith(".h5")) else \
                default_table_path(tl_table)
            self.tl = TLTable.load(path).range_profile(src_depth_m, rcv_depth_m)
        if not self.sigma_level > 0:
            raise ConfigError("tracker: rpf sigma_level_db must be > 0")
        if not max_speed_kn >= 0:
            raise ConfigError("tracker: rpf max_speed_kn must be >= 0 (0: no limit)")
        self.v_max = float(max_speed_kn) * KNOT
        self.n = int(n_particles)
        self.n_thr = float(n_thr)
        self.sigma_a = sigma_a
        self.method = 0 if resampling == "systematic" else 1
        self.h = float(bandwidth_scale) * kpf.bandwidth(self.n)
        self.state = np.array([run_seeds(int(seed), 1, tag=3)[0]], dtype=np.uint64)
        self.parts = np.zeros((self.n, 4))      # relative states between calls
        self.w = np.ones(self.n)
        self.s = float(self.n)
        self._scratch = (np.empty(self.n), np.empty(self.n), np.empty(self.n, np.int64),
                         np.empty((self.n, 4)), np.empty(4), np.empty((4, 4)), np.empty((4, 4)))
        self.x = np.zeros(4)
        self.P = np.eye(4)
        self._pending: tuple | None = None
        self.n_resampled = 0

    def initialize(self, x0: np.ndarray, P0: np.ndarray) -> None:
        x0 = np.asarray(x0, float).reshape(4)
        d = np.linalg.cholesky(np.asarray(P0, float).reshape(4, 4))
        z = kpf.normal_block(self.state, 2 * self.n).reshape(self.n, 4)
        self.parts = x0 + z @ d.T
        self.w[:] = 1.0
        self.s = float(self.n)
        self.x, self.P = x0.copy(), np.asarray(P0, float).reshape(4, 4).copy()

    def predict(self, T: float, own_prev: np.ndarray, own_next: np.ndarray) -> None:
        """Store the step; the particles move in :meth:`update` (one fused kernel)."""
        self._pending = (float(T), np.asarray(own_prev, float), np.asarray(own_next, float))

    def update(self, bearing_deg: float, level_db: float | None = None) -> float:
        from arrayproc.track.filters import FilterDivergence

        use_level = level_db is not None and math.isfinite(level_db)
        if use_level and not self.has_tl:
            raise ConfigError("tracker: levels given to the rpf filter without a tl_table")

        if self._pending is None:
            T, own_prev, own_next = 0.0, np.zeros(4), np.zeros(4)
        else:
            T, own_prev, own_next = self._pending
        self._pending = None
        sa = self.sigma_a if self.sigma_a is not None else (
            math.sqrt(self.model.q1 / T) if T > 0 else 0.0)
        ww, ll, idx, src, mean, pcov, dmat = self._scratch
        absolute = self.parts + own_prev               # eq. (4): x + x^o, then F, then − x^o'
        r0, dr, tl = self.tl
        s, logev, done = kpf.rpf_step(absolute, self.w, ww, self.s, ll, self.state, T, sa,
                                      own_next[0], own_next[1], math.radians(bearing_deg),
                                      self.sigma, float(level_db) if use_level else 0.0,
                                      self.sigma_level, use_level, self.sl_par, r0, dr, tl,
                                      self.n_thr, self.method, self.h, idx, src, mean, pcov,
                                      dmat, self.v_max)
        self.parts = absolute - own_next
        self.s = s
        self.n_resampled += int(done)
        self.x = mean - own_next
        self.P = pcov.copy()
        if not (np.all(np.isfinite(self.x)) and np.all(np.isfinite(self.P))):
            raise FilterDivergence("rpf: non-finite state")
        norm = math.log(math.sqrt(2 * math.pi) * self.sigma)
        if use_level:
            norm += math.log(math.sqrt(2 * math.pi) * self.sigma_level)
        return float(logev - norm)
