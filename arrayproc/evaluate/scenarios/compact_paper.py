"""Compact-array paper: a Fig. 1 analogue by simulation, RMSE of range and heading at the CPA.

The paper's Fig. 1 comes from 171 real vessels passing a seabed tetrahedral array (1.84 m
between hydrophones; only azimuths used) with a mean vessel speed of 7.3 m/s. We simulate the
same estimator (paper eqs. (1)-(5), :mod:`arrayproc.track.batch.compact`): a static array at
the origin, a vessel at 7.3 m/s on heading 30° whose CPA distance runs from 100 m to 3 km,
observed for 20 min centred on the CPA with a bearing every 4 s (301 bearings), Gaussian
bearing errors of σ = 2° (our assumption: the paper gives no σ), either independent or
exponentially correlated (τ = 30 s). Cases:

- ``diagonal``: independent errors, diagonal C;
- ``full``: correlated errors, full (exponential) C;
- ``mismatched``: correlated errors, diagonal C (what ignoring the correlation costs);
- ``speed_error``: the vessel actually at 6.0 or 9.0 m/s, the estimator assuming 7.3 m/s
  (independent errors, diagonal C) — the drift of range and heading.

The RMSE of the range (from the array, at the true CPA time) and of the heading are compared
with the CRLB from the Fisher information with C (speed known); target: within
25 % for ``diagonal`` and ``full``. The speed-error rows also give the bound with a speed
prior σ_v = 1.5 m/s.

:func:`sweeps` varies, one at a time, the four factors the paper names (correlation
interval τ, bearing σ, observation time T, speed-prior σ_v, the true speed then drawn from
the prior) at CPA 1 km and 3 km against the CRLB; the paper shows no figure of these, so the
values (:data:`SWEEPS`) are ours.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.integrate import quad
from scipy.stats import truncnorm

from arrayproc.evaluate.accuracy import crlb_ratio, rmse
from arrayproc.track.batch.compact import compact_bearings, cpa_range_heading, solve_compact
from arrayproc.track.batch.fim import compact_fim, crlb_from_fim, innovation_coefficients

__all__ = ["SPEED", "HEADING", "DURATION", "DT", "SIGMA", "CORR", "SIGMA_SPEED", "CPAS",
           "CASES", "truth", "ou_noise", "cpa_bounds", "run_case", "fig_1", "SWEEP_BASE",
           "SWEEPS", "SWEEP_CPAS", "MIN_SPEED", "sweep_bounds", "draw_speed",
           "scale_model_range", "expected_scale_range", "sweep_run",
           "sweep_point", "sweeps"]

SPEED = 7.3
HEADING = np.deg2rad(30.0)
DURATION = 1200.0
DT = 4.0
SIGMA = np.deg2rad(2.0)
CORR = 30.0
SIGMA_SPEED = 1.5
CPAS = (100.0, 300.0, 1000.0, 2000.0, 3000.0)


def truth(d_cpa: float, speed: float = SPEED, duration: float = DURATION) -> np.ndarray:
    """(x0, y0, γ) of paper eq. (2): the vessel passes (d cos γ, −d sin γ) at the middle of
    a window of ``duration`` s."""
    pc = d_cpa * np.array([np.cos(HEADING), -np.sin(HEADING)])
    p0 = pc - speed * duration / 2 * np.array([np.sin(HEADING), np.cos(HEADING)])
    return np.array([p0[0], p0[1], HEADING])


def ou_noise(rng: np.random.Generator, t: np.ndarray, corr: float,
             sigma: float = SIGMA) -> np.ndarray:
    """Bearing errors ε(t) of paper eq. (3), std ``sigma`` (rad), exponentially correlated
    with time constant ``corr`` s (0: independent), drawn as the AR(1) recursion of the
    paper's innovations."""
    phi, _ = innovation_coefficients(t, sigma, corr)
    e = np.empty(t.size)
    e[0] = rng.normal() * sigma
    for b in range(1, t.size):
        e[b] = phi[b] * e[b - 1] + np.sqrt(1 - phi[b] ** 2) * sigma * rng.normal()
    return e


def cpa_bounds(q: np.ndarray, t: np.ndarray, corr: float, sigma_speed: float,
               sigma: float = SIGMA, duration: float = DURATION) -> tuple:
    """CRLB (m, deg) of the range at the CPA time (mid-window of ``duration`` s) and of the
    heading, from the Fisher information of paper eq. (4) with bearing std ``sigma`` (rad),
    correlation time ``corr`` (s) and speed prior ``sigma_speed`` (m/s, 0: known speed)."""
    f = compact_fim(q, SPEED, t, [0.0, 0.0], sigma, corr, sigma_speed)
    p, _ = crlb_from_fim(f)
    tc = duration / 2
    g = q[2]
    pos = q[:2] + SPEED * tc * np.array([np.sin(g), np.cos(g)])
    u = pos / np.hypot(*pos)
    grad = np.array([u[0], u[1], u @ (SPEED * tc * np.array([np.cos(g), -np.sin(g)])),
                     u @ (tc * np.array([np.sin(g), np.cos(g)]))])[:p.shape[0]]
    return float(np.sqrt(grad @ p @ grad)), float(np.rad2deg(np.sqrt(p[2, 2])))


def run_case(d: float, case: str, runs: int, rng: np.random.Generator, n_grid: int,
             n_headings: int) -> dict:
    """``runs`` runs of one case at CPA distance ``d`` (m): range (m) and heading (deg) RMSE,
    bias and ratio to the CRLB, per true speed (the module docstring's cases)."""
    t = np.arange(0.0, DURATION + 1e-9, DT)
    speeds = (6.0, 9.0) if case == "speed_error" else (SPEED,)
    corr_true = CORR if case in ("full", "mismatched") else 0.0
    corr_est = CORR if case == "full" else 0.0
    out = {}
    for v in speeds:
        q = truth(d, v)
        h = compact_bearings(q, v, t, [0.0, 0.0])
        r_err, g_err = [], []
        for _ in range(runs):
            y = h + ou_noise(rng, t, corr_true)
            sol = solve_compact(t, y, [0.0, 0.0], SIGMA, speed_mps=SPEED,
                                correlation_s=corr_est, max_range_m=1.3 * (v * DURATION / 2 + d),
                                n_grid=n_grid, n_headings=n_headings)
            qe = np.array([sol.state[0], sol.state[1], np.arctan2(sol.state[2], sol.state[3])])
            r_hat, g_hat = cpa_range_heading(qe, SPEED, [0.0, 0.0], DURATION / 2)
            r_err.append(r_hat - d)
            g_err.append(np.rad2deg((g_hat - HEADING + np.pi) % (2 * np.pi) - np.pi))
        r_err, g_err = np.array(r_err), np.array(g_err)
        qn = truth(d)
        crlb_r, crlb_g = cpa_bounds(qn, t, corr_true, 0.0)
        key = "v" if len(speeds) == 1 else f"v={v:.1f}"
        out[key] = {
            "true_speed_mps": v, "rmse_range_m": float(rmse(r_err)),
            "bias_range_m": float(r_err.mean()), "rmse_heading_deg": float(rmse(g_err)),
            "bias_heading_deg": float(g_err.mean()),
            "crlb_range_m": crlb_r, "crlb_heading_deg": crlb_g,
            "ratio_range": float(crlb_ratio(rmse(r_err), crlb_r)),
            "ratio_heading": float(crlb_ratio(rmse(g_err), crlb_g))}
        if case == "speed_error":
            br, bg = cpa_bounds(qn, t, 0.0, SIGMA_SPEED)
            out[key]["crlb_range_with_speed_prior_m"] = br
            out[key]["crlb_heading_with_speed_prior_deg"] = bg
            out[key]["predicted_range_bias_m"] = float(d * (SPEED / v - 1))
    return out


CASES = ("diagonal", "full", "mismatched", "speed_error")


def fig_1(runs: int, seed: int, n_grid: int = 60, n_headings: int = 72,
          log: Callable[[str, float, dict], None] | None = None) -> dict:
    """Every case at every CPA distance of :data:`CPAS`, all drawing from one
    ``numpy.random.default_rng(seed)`` in that order; ``log(case, d, result)`` after each.

    Returns
    -------
    dict
        ``{"cases": {case: {"<d>": run_case result}}, "target_met": bool}``: diagonal and
        full within 25 % of the CRLB at every CPA.
    """
    rng = np.random.default_rng(seed)
    cases: dict = {}
    for case in CASES:
        cases[case] = {}
        for d in CPAS:
            r = run_case(d, case, runs, rng, n_grid, n_headings)
            cases[case][f"{int(d)}"] = r
            if log is not None:
                log(case, d, r)
    met = all(abs(cases[c][f"{int(d)}"]["v"][f"ratio_{q}"] - 1) <= 0.25
              for c in ("diagonal", "full") for d in CPAS for q in ("range", "heading"))
    return {"cases": cases, "target_met": met}


# -- parameter sweeps ------------------------------------------------------------------------
# The paper names four factors whose influence on the range and heading accuracy it sets out
# to evaluate: the correlation interval, the variance of the bearing errors, the observation
# interval and the variance of the speed errors. Its only figure (Fig. 1) is the sweep over
# the CPA distance, so the values below are ours, around the Fig. 1 analogue's setting.

SWEEP_BASE = {"correlation_s": CORR, "sigma_deg": 2.0, "duration_s": DURATION,
              "sigma_speed_mps": 0.0}
SWEEPS = {"correlation_s": (0.0, 10.0, 30.0, 60.0, 120.0),
          "sigma_deg": (0.5, 1.0, 2.0, 4.0),
          "duration_s": (300.0, 600.0, 1200.0, 2400.0),
          "sigma_speed_mps": (0.0, 0.5, 1.5, 3.0)}
SWEEP_CPAS = (1000.0, 3000.0)
MIN_SPEED = 1.0


def sweep_bounds(d_cpa: float, setting: dict) -> tuple[float, float]:
    """CRLB (m, deg) of the range at the CPA and of the heading for one sweep point.

    Parameters
    ----------
    d_cpa : float
        CPA distance (m).
    setting : dict
        ``correlation_s`` (s), ``sigma_deg``, ``duration_s`` (s) and ``sigma_speed_mps``
        (m/s; 0: known speed), as in :data:`SWEEP_BASE`.

    Returns
    -------
    crlb_range_m, crlb_heading_deg : float
        From ``J = Gᵀ C⁻¹ G + diag(0, 0, 0, 1/σ_v²)`` (paper eq. (4) with the speed prior),
        evaluated at the true track at the mean speed 7.3 m/s.
    """
    dur = setting["duration_s"]
    t = np.arange(0.0, dur + 1e-9, DT)
    return cpa_bounds(truth(d_cpa, SPEED, dur), t, setting["correlation_s"],
                      setting["sigma_speed_mps"], np.deg2rad(setting["sigma_deg"]), dur)


def draw_speed(rng: np.random.Generator, sigma_speed: float) -> float:
    """True speed of one run: the prior N(7.3, σ_v²) redrawn below :data:`MIN_SPEED` (a vessel
    under way; 1.8 % of the draws at σ_v = 3 m/s); 7.3 m/s when ``sigma_speed = 0``."""
    if sigma_speed <= 0:
        return SPEED
    while True:
        v = float(rng.normal(SPEED, sigma_speed))
        if v >= MIN_SPEED:
            return v


def scale_model_range(d_cpa: float, k: np.ndarray, crlb_known_m: float) -> float:
    """Range RMSE at the CPA that the exact range-speed scaling predicts.

    Bearings from a static array are unchanged by ``(r, v) → (k r, k v)`` (paper eqs. (1),
    (3)), so the estimate at the assumed speed is ``k = 7.3/v`` times the one at the true
    speed v, whose range error n has std ``crlb_known_m``: the error is ``(k − 1) d + k n``.

    Parameters
    ----------
    d_cpa : float
        CPA distance (m).
    k : array_like
        Ratios of assumed to true speed, one per run (or quadrature node).
    crlb_known_m : float
        Range CRLB with the speed known (m).

    Returns
    -------
    float
        ``√(mean((k − 1)² d² + k² crlb_known²))``.
    """
    k = np.asarray(k, float)
    return float(np.sqrt(np.mean((k - 1) ** 2 * d_cpa**2 + k**2 * crlb_known_m**2)))


def expected_scale_range(d_cpa: float, sigma_speed: float, crlb_known_m: float) -> float:
    """:func:`scale_model_range` averaged over the speed prior of :func:`draw_speed` (the
    normal N(7.3, σ_v²) truncated at :data:`MIN_SPEED`), by quadrature."""
    if sigma_speed <= 0:
        return float(crlb_known_m)
    dist = truncnorm((MIN_SPEED - SPEED) / sigma_speed, np.inf, loc=SPEED, scale=sigma_speed)
    lo, hi = max(MIN_SPEED, SPEED - 12 * sigma_speed), SPEED + 12 * sigma_speed
    m1 = quad(lambda v: ((SPEED / v - 1) * d_cpa) ** 2 * dist.pdf(v), lo, hi, points=[SPEED],
              limit=200)[0]
    m2 = quad(lambda v: (SPEED / v) ** 2 * dist.pdf(v), lo, hi, points=[SPEED], limit=200)[0]
    return float(np.sqrt(m1 + m2 * crlb_known_m**2))


def sweep_run(d_cpa: float, setting: dict, rng: np.random.Generator, n_grid: int,
              n_headings: int) -> tuple[float, float, float]:
    """One run of a sweep point: errors of the range at the CPA (m) and of the heading (deg).

    The true speed is drawn by :func:`draw_speed`, the bearings (paper eqs. (1), (3)) carry
    exponentially correlated errors, and :func:`solve_compact` (eq. (5)) uses the full C and
    the mean speed 7.3 m/s; its grid spans the window's track at that speed.

    Returns
    -------
    range_err_m, heading_err_deg, true_speed_mps : float
    """
    dur, corr = setting["duration_s"], setting["correlation_s"]
    sig = np.deg2rad(setting["sigma_deg"])
    t = np.arange(0.0, dur + 1e-9, DT)
    v = draw_speed(rng, setting["sigma_speed_mps"])
    y = compact_bearings(truth(d_cpa, v, dur), v, t, [0.0, 0.0]) + ou_noise(rng, t, corr, sig)
    sol = solve_compact(t, y, [0.0, 0.0], sig, speed_mps=SPEED, correlation_s=corr,
                        max_range_m=1.3 * (SPEED * dur / 2 + d_cpa), n_grid=n_grid,
                        n_headings=n_headings)
    qe = np.array([sol.state[0], sol.state[1], np.arctan2(sol.state[2], sol.state[3])])
    r_hat, g_hat = cpa_range_heading(qe, SPEED, [0.0, 0.0], dur / 2)
    g_err = np.rad2deg((g_hat - HEADING + np.pi) % (2 * np.pi) - np.pi)
    return r_hat - d_cpa, float(g_err), v


def sweep_point(d_cpa: float, setting: dict, runs: int, seed: np.random.SeedSequence,
                n_grid: int = 50, n_headings: int = 36) -> dict:
    """``runs`` runs of one sweep point against its CRLB (:func:`sweep_bounds`).

    Returns
    -------
    dict
        RMSE, bias, CRLB and RMSE/CRLB of the range at the CPA (m) and of the heading (deg);
        ``scale_model_range_m``: the range RMSE that the exact range-speed scaling predicts
        over the drawn speeds (:func:`scale_model_range`), ``expected_scale_range_m`` the same
        over the prior (:func:`expected_scale_range`).
    """
    rng = np.random.default_rng(seed)
    out = np.array([sweep_run(d_cpa, setting, rng, n_grid, n_headings) for _ in range(runs)])
    r_err, g_err, v = out.T
    crlb_r, crlb_g = sweep_bounds(d_cpa, setting)
    known_r, _ = sweep_bounds(d_cpa, {**setting, "sigma_speed_mps": 0.0})
    return {"rmse_range_m": float(rmse(r_err)), "bias_range_m": float(r_err.mean()),
            "rmse_heading_deg": float(rmse(g_err)), "bias_heading_deg": float(g_err.mean()),
            "crlb_range_m": crlb_r, "crlb_heading_deg": crlb_g,
            "ratio_range": float(crlb_ratio(rmse(r_err), crlb_r)),
            "ratio_heading": float(crlb_ratio(rmse(g_err), crlb_g)),
            "scale_model_range_m": scale_model_range(d_cpa, SPEED / v, known_r),
            "expected_scale_range_m": expected_scale_range(d_cpa, setting["sigma_speed_mps"],
                                                           known_r),
            "min_speed_mps": float(v.min()),
            "max_speed_mps": float(v.max())}


def sweeps(runs: int, seed: int, cpas: tuple[float, ...] = SWEEP_CPAS, n_grid: int = 50,
           n_headings: int = 36,
           log: Callable[[float, str, float, dict], None] | None = None) -> dict:
    """The four factor sweeps of :data:`SWEEPS` at each CPA distance, one factor varied from
    :data:`SWEEP_BASE` at a time (paper eqs. (1)-(5) against the CRLB).

    Each point draws from ``SeedSequence([seed, i_cpa, i_sweep, i_value])`` so any point can
    be re-run alone; ``log(d, factor, value, result)`` after each.

    Returns
    -------
    dict
        ``{"<d>": {factor: {"<value>": sweep_point result}}}``.
    """
    res: dict = {}
    for ic, d in enumerate(cpas):
        res[f"{int(d)}"] = {}
        for js, (name, values) in enumerate(SWEEPS.items()):
            res[f"{int(d)}"][name] = {}
            for kv, val in enumerate(values):
                seq = np.random.SeedSequence([seed, ic, js, kv])
                r = sweep_point(d, {**SWEEP_BASE, name: val}, runs, seq, n_grid, n_headings)
                res[f"{int(d)}"][name][f"{val:g}"] = r
                if log is not None:
                    log(d, name, val, r)
    return res
