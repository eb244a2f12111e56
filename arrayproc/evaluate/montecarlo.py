"""Monte Carlo evaluation of the bearings-only trackers on the L-R paper's section-V scenario.

Runs are independent and executed by the fused L-R kernel
(:func:`arrayproc.track.manage.lr.run_lr_batch`) on a thread pool; the noise of every run comes
from one seeded generator, so the same seed gives the same bytes.

Scenario (L-R paper section V; Ristic, Arulampalam & Gordon 2003 ch. 6): T = 1 min for 30 min
(31 bearings, t = 0 … 30 min); observer at the origin, 5 kn on 140°, turning to 20° at 30°/min
between 13 and 17 min; target starting at [5000, 800] m (the SPL paper's version of this
geometry, range 5.06 km), 4 kn on −140°, straight (Case I) or turning at 3°/min anticlockwise
(Case II, ψ > 0 in eq. (5)); σθ = 1.5°. The target track is deterministic (no process noise in
the truth); the filters still carry the paper's q̄1, q̄2.
"""

from __future__ import annotations

import math
import os
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np

from arrayproc.geo.angles import true_bearing, wrap_pi
from arrayproc.geo.kinematics import KNOT, Leg, Trajectory
from arrayproc.track.crlb import bearings_only_crlb, polar_prior_covariance, position_rmse_bound
from arrayproc.track.filters import make_filter
from arrayproc.track.init import TrackPrior
from arrayproc.track.manage.lr import run_lr_batch
from arrayproc.track.models.motion import make_model

TRACK_BOUND_M = 1000.0


@dataclass(frozen=True)
class LRScenario:
    """The section-V geometry; ``case`` 1 (CV target) or 2 (CT target, 3°/min)."""

    case: int = 1
    dt: float = 60.0
    duration: float = 1800.0
    sigma_deg: float = 1.5
    target_start: tuple[float, float] = (5000.0, 800.0)
    target_speed: float = 4.0 * KNOT
    target_course_deg: float = -140.0
    target_turn_deg_min: float = 3.0  # anticlockwise (eq. (5) ψ > 0), Case II only
    observer_speed: float = 5.0 * KNOT
    prior: TrackPrior = field(default_factory=TrackPrior)
    random_init: bool = True  # initial mean drawn from the prior in every run
    truth_noise: bool = False  # target driven by the model's process noise (eqs. (4), (6))

    @property
    def model_name(self) -> str:
        return "cv" if self.case == 1 else "ct"

    @property
    def times(self) -> np.ndarray:
        return np.arange(0.0, self.duration + 0.5 * self.dt, self.dt)

    def observer(self) -> Trajectory:
        v = self.observer_speed
        return Trajectory.from_legs((0.0, 0.0), [
            {"course": 140.0, "speed": v, "duration": 780.0},
            {"course": 20.0, "speed": v, "duration": self.duration - 780.0, "turn_rate": 0.5},
        ])

    def target(self) -> Trajectory:
        rate = 0.0 if self.case == 1 else -self.target_turn_deg_min / 60.0  # deg/s clockwise
        return Trajectory(self.target_start, self.target_course_deg,
                          [Leg(self.duration, self.target_speed, rate)])

    def geometry(self) -> dict[str, np.ndarray]:
        """Observer state (K, 4), heading (K,) rad, target state (K, 4), relative truth (K, n)."""
        t = self.times
        op, ov, oc = self.observer().state(t)
        tp, tv, _ = self.target().state(t)
        own = np.hstack([op, ov])
        tgt = np.hstack([tp, tv])
        rel = tgt - own
        if self.case == 2:
            psi = math.radians(self.target_turn_deg_min / 60.0)
            rel = np.hstack([rel, np.full((t.size, 1), psi)])
        return {"times": t, "own": own, "heading": np.deg2rad(oc), "target": tgt, "rel": rel}

    def truth(self, runs: int, rng: np.random.Generator) -> np.ndarray:
        """Relative true state per run (runs, K, n): the deterministic track, or with
        ``truth_noise`` the target propagated by eq. (1) with process noise drawn from Q."""
        g = self.geometry()
        rel = np.broadcast_to(g["rel"], (runs,) + g["rel"].shape)
        if not self.truth_noise:
            return rel
        model = make_model(self.model_name)
        K, n = g["rel"].shape
        own = g["own"]
        out = np.empty((runs, K, n))
        out[:, 0] = g["rel"][0]
        for k in range(1, K):
            T = self.times[k] - self.times[k - 1]
            Lq = np.linalg.cholesky(model.covariance(T))
            w = rng.standard_normal((runs, n)) @ Lq.T
            prev = out[:, k - 1]
            absx = prev[:, :4] + own[k - 1]
            if n == 4:
                nxt = absx.copy()
                nxt[:, :2] += T * absx[:, 2:]
            else:
                psi = prev[:, 4]
                wt = psi * T
                small = np.abs(wt) < 1e-9
                a = np.where(small, T, np.sin(wt) / np.where(small, 1.0, psi))
                b = np.where(small, 0.0, (1.0 - np.cos(wt)) / np.where(small, 1.0, psi))
                c, s_ = np.cos(wt), np.sin(wt)
                nxt = np.empty_like(absx)
                nxt[:, 0] = absx[:, 0] + a * absx[:, 2] - b * absx[:, 3]
                nxt[:, 1] = absx[:, 1] + b * absx[:, 2] + a * absx[:, 3]
                nxt[:, 2] = c * absx[:, 2] - s_ * absx[:, 3]
                nxt[:, 3] = s_ * absx[:, 2] + c * absx[:, 3]
            out[:, k, :4] = nxt - own[k] + w[:, :4]
            if n == 5:
                out[:, k, 4] = psi + w[:, 4]
        return out

    def measurements(self, runs: int, seed: int) -> tuple[np.ndarray, ...]:
        """True-side bearings y¹ = γ(X) + ν (eq. (7)) and mirrors y² = 2h − γ(X) − ν (eq. (8)),
        rad, each (runs, K) — hypothesis 0 is the true side — and the initialisation draws
        (runs, 3): range r ~ N(r̄, σr²), speed s ~ N(s̄, σs²) and course offset ~ N(0, σc²) of
        the initial mean (Ristic et al. 2003 ch. 6), or the prior mean when ``random_init`` is
        false; last, the relative truth (runs, K, n)."""
        g = self.geometry()
        rng = np.random.default_rng(seed)
        rel = self.truth(runs, rng)
        theta = np.arctan2(rel[..., 0], rel[..., 1])
        nu = rng.standard_normal(theta.shape) * math.radians(self.sigma_deg)
        y1 = wrap_pi(theta + nu)
        y2 = wrap_pi(2.0 * g["heading"][None, :] - theta - nu)
        p = self.prior
        draws = np.empty((runs, 3))
        draws[:] = (p.range_m, p.speed_mps, 0.0)
        if self.random_init:
            e = rng.standard_normal((runs, 3))
            draws += e * (p.sigma_range_m, p.sigma_speed_mps, math.radians(p.sigma_course_deg))
            # a negative draw of range or speed flips the direction: keep them positive
            draws[:, :2] = np.abs(draws[:, :2])
        return y1, y2, draws, rel


@dataclass
class MCResult:
    """Per-run estimates and the summary statistics of one filter on one case."""

    filter: str
    case: int
    resolved: bool
    est: np.ndarray        # (R, K, 4) combined estimate, eq. (12)
    weights: np.ndarray    # (R, K, n_hyp)
    status: np.ndarray     # (R,)
    lost: np.ndarray       # (R,) bool
    rmse_pos: np.ndarray   # (K,) m, over the runs not lost
    rmse_vel: np.ndarray   # (K,) m/s
    bias_norm: np.ndarray  # (K,) m, ‖mean position error‖ over the runs not lost
    seconds: float

    @property
    def track_loss_pct(self) -> float:
        return 100.0 * float(self.lost.mean())

    @property
    def true_side_pct(self) -> float:
        """% of the runs not lost whose final weight favours the true side (hypothesis 0)."""
        ok = ~self.lost
        if not ok.any():
            return float("nan")
        return 100.0 * float((self.weights[ok, -1, 0] > 0.5).mean())

    @property
    def n_repaired(self) -> int:
        return int(((self.status & 1) != 0).sum())

    @property
    def n_diverged(self) -> int:
        return int(((self.status & 4) != 0).sum())


def run_case(scn: LRScenario, filter_name: str, resolved: bool, runs: int, seed: int,
             filter_params: dict | None = None,
             meas: tuple[np.ndarray, ...] | None = None,
             threads: int | None = None) -> MCResult:
    """Run ``runs`` Monte Carlo runs of one filter, known side (one filter on y¹) or resolved
    (the two-hypothesis scheme on y¹, y², eqs. (9)-(13)), on ``threads`` threads (default:
    the number of usable cores). The result does not depend on the number of threads."""
    g = scn.geometry()
    model = make_model(scn.model_name)
    filt = make_filter(filter_name, **(filter_params or {}))
    y1, y2, draws, rel = meas if meas is not None else scn.measurements(runs, seed)
    zs = np.stack([y1, y2], axis=-1) if resolved else y1[..., None]
    zs = np.ascontiguousarray(zs)
    prior = scn.prior.as_array()
    prior[4] = math.radians(scn.sigma_deg)
    t0 = time.perf_counter()
    est, wts, status = _run_threads(filt, model, zs, g["times"], g["own"],
                                    math.radians(scn.sigma_deg), prior,
                                    np.ascontiguousarray(draws), threads)
    seconds = time.perf_counter() - t0
    truth = rel[..., :4]
    err = est - truth
    r_est = np.hypot(est[:, -1, 0], est[:, -1, 1])
    r_true = np.hypot(truth[:, -1, 0], truth[:, -1, 1])
    lost = (np.abs(r_est - r_true) > TRACK_BOUND_M) | ((status & 4) != 0) | ~np.isfinite(r_est)
    ok = ~lost
    if ok.any():
        e = err[ok]
        rmse_pos = np.sqrt(np.mean(e[..., 0] ** 2 + e[..., 1] ** 2, axis=0))
        rmse_vel = np.sqrt(np.mean(e[..., 2] ** 2 + e[..., 3] ** 2, axis=0))
        bias = np.linalg.norm(e[..., :2].mean(axis=0), axis=-1)
    else:
        rmse_pos = rmse_vel = bias = np.full(truth.shape[1], np.nan)
    return MCResult(filter_name, scn.case, resolved, est, wts, status, lost, rmse_pos, rmse_vel,
                    bias, seconds)


def default_threads() -> int:
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover
        return max(1, os.cpu_count() or 1)


def _run_threads(filt, model, zs, times, own, sigma, prior, draws, threads):
    """Split the runs into contiguous chunks and run the GIL-free kernel on a thread pool."""
    R, K, n_hyp = zs.shape
    est = np.empty((R, K, 4))
    wts = np.empty((R, K, n_hyp))
    n = model.ndim
    Pfin = np.empty((R, n, n))
    status = np.empty(R, dtype=np.int64)
    nthr = max(1, min(threads or default_threads(), R))
    bounds = np.linspace(0, R, 4 * nthr + 1 if R >= 4 * nthr else nthr + 1).astype(int)

    def work(i):
        a, b = bounds[i], bounds[i + 1]
        if b > a:
            run_lr_batch(filt, model, sigma, times, zs[a:b], own, prior, draws[a:b], est[a:b],
                         wts[a:b], Pfin[a:b], status[a:b])

    if nthr == 1:
        for i in range(len(bounds) - 1):
            work(i)
    else:
        with ThreadPoolExecutor(nthr) as ex:
            list(ex.map(work, range(len(bounds) - 1)))
    return est, wts, status


def warm_up(filter_names: list[str], filter_params: dict | None = None) -> None:
    """Compile the kernels (both models, both hypothesis counts) so timings exclude JIT."""
    for case in (1, 2):
        scn = LRScenario(case=case)
        for name in filter_names:
            for resolved in (False, True):
                run_case(scn, name, resolved, 2, 0, (filter_params or {}).get(name))


def pcrb_case1(scn: LRScenario) -> np.ndarray:
    """Position RMSE bound (m) over time for Case I: bearings-only CRLB with zero process noise
    (Ristic et al. 2003 ch. 4/6), prior information = inverse of the initialisation covariance
    at the true first bearing (:func:`arrayproc.track.crlb.bearings_only_crlb`)."""
    g = scn.geometry()
    p = scn.prior
    b0 = float(true_bearing(g["rel"][0, 0], g["rel"][0, 1]))
    P0 = polar_prior_covariance(b0, p.range_m, math.radians(scn.sigma_deg), p.sigma_range_m,
                                p.speed_mps, b0 + math.pi, p.sigma_speed_mps,
                                math.radians(p.sigma_course_deg))
    crlb = bearings_only_crlb(g["target"][0], g["times"], g["own"][:, :2],
                              math.radians(scn.sigma_deg), np.linalg.inv(P0))
    return position_rmse_bound(crlb)
