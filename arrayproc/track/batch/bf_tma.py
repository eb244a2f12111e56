"""Bearings + frequency batch TMA: narrowband towed-array TMA with an unknown rest frequency.

The source moves at constant velocity over the window (thesis eq. (3.41)) and radiates a tonal
of unknown rest frequency ``f0``; the array measures, at each time ``t_b``, the bearing of
eq. (3.44) (or, on a line array, its cone angle ``|wrap(h_b − ψ_b)|``, :func:`.bo_tma.cone_model`)
and the received frequency

    f_b = f0 (1 − ṙ_b / c),    ṙ_b = d_b · (v − v_o,b) / |d_b|                    (BF1)

(first-order Doppler; ``d_b`` the source minus the observer, ``v`` the source's and ``v_o,b``
the observer's velocity; ``ṙ`` opening positive). The unknowns are ``[x, y, ẋ, ẏ, f0]``
(thesis section 3.4; table 3.1's refs [71, 73]). Gaussian errors of σ_θ and σ_f give the
weighted least-squares cost

    C(x, f0) = Σ_b (θ_b − h_b(x))² / σ_θ² + Σ_b (f_b − f0 g_b(x))² / σ_f²,   g_b = 1 − ṙ_b / c

which is quadratic in ``f0``: for each kinematic state its minimum is at
``f0 = Σ g f / Σ g²`` (BF2), so the global search (differential evolution over the same
bearing/range coordinates as the bearings-only solver, numba population kernel
:func:`._kernels.bf_cost_population`) runs on the four kinematic parameters only, and the
least-squares polish on all five. The Fisher information is ``Jᵀ Σ⁻¹ J`` over both measurement
kinds (BF3: the bearing rows of :func:`.fim.bo_jacobian`, signed for cone angles, and the
frequency rows ``∂(f0 g_b)/∂[x, f0]``); its inverse is the CRLB of all five parameters.

Written here (no maintained library solves it): the frequency rows, their Jacobian and the
profiled cost are a few lines over the bearings-only solver's parts.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.optimize import leastsq

from ._kernels import bf_cost_population
from .bo_tma import (
    _observer_at,
    _wrap,
    bearing_model,
    cone_model,
    end_side_searches,
    reject_outliers,
)
from .evolution import evolve
from .fim import bo_jacobian
from .motion import emission_derivative, emission_points
from .result import PolarSearch, TmaSolution, end_value, finish_solution

__all__ = ["doppler_factor", "range_rate_gradient", "noise_scale", "solve_bearings_frequency"]


def _emission(x: np.ndarray, tau: np.ndarray, obs: np.ndarray, retarded_c: float | None
              ) -> tuple[np.ndarray, np.ndarray]:
    """Source positions the rows see (B, 2) and their times since t0 (B,): at the reception
    times, or at the emission times with a sound speed (eq. (M5) of :mod:`.motion`)."""
    tau = np.asarray(tau, float)
    if retarded_c:
        return emission_points(x[:4], tau, obs, retarded_c)
    return x[None, :2] + tau[:, None] * x[None, 2:4], tau


def doppler_factor(state: np.ndarray, tau: np.ndarray, obs: np.ndarray, obs_vel: np.ndarray,
                   sound_speed: float, retarded: bool = False) -> np.ndarray:
    """``g_b = 1 − ṙ_b / c`` of eq. (BF1) for the kinematic state ``[x, y, ẋ, ẏ]`` at the
    window start (m, m/s); ``tau`` (B,) s; ``obs``, ``obs_vel`` (B, 2) m and m/s;
    ``retarded``: ``d`` from the source's emission point (eq. (M5) of :mod:`.motion`)."""
    x = np.asarray(state, float)
    p, _ = _emission(x, tau, obs, sound_speed if retarded else None)
    d = p - obs
    u = x[None, 2:4] - obs_vel
    return 1.0 - np.sum(d * u, axis=1) / np.hypot(d[:, 0], d[:, 1]) / sound_speed


def range_rate_gradient(state: np.ndarray, tau: np.ndarray, obs: np.ndarray,
                        obs_vel: np.ndarray, retarded_c: float | None = None) -> np.ndarray:
    """``∂ṙ_b/∂[x, y, ẋ, ẏ]`` (B, 4): with ``d = p + τ v − o``, ``u = v − v_o``, ``r = |d|``,
    ``∂ṙ/∂p = u/r − (d·u) d / r³`` and ``∂ṙ/∂v = τ ∂ṙ/∂p + d/r``; with ``retarded_c`` the
    emission point ``p_e`` (τ_e its time) in place of ``p + τ v``, ``∂ṙ/∂p0 = ∂ṙ/∂p_e M⁻¹``
    and ``∂ṙ/∂v = τ_e ∂ṙ/∂p_e M⁻¹ + d/r`` (:func:`.motion.emission_derivative`)."""
    x = np.asarray(state, float)
    p, tau_e = _emission(x, tau, obs, retarded_c)
    d = p - obs
    u = x[None, 2:4] - obs_vel
    r = np.hypot(d[:, 0], d[:, 1])[:, None]
    dp = u / r - np.sum(d * u, axis=1)[:, None] * d / r**3
    if retarded_c:
        dp = np.einsum("bi,bij->bj", dp, emission_derivative(x[:4], p, obs, retarded_c))
    return np.concatenate([dp, tau_e[:, None] * dp + d / r], axis=1)


def _model(q: np.ndarray, tau: np.ndarray, obs: np.ndarray, obs_vel: np.ndarray,
           heading: np.ndarray | None, c: float, cr: float | None = None
           ) -> tuple[np.ndarray, np.ndarray]:
    """Angles (bearings, or cone angles on ``heading``) and frequencies of ``[x, f0]``
    (``cr``: the sound speed of the retarded model, None without)."""
    ang = (bearing_model(q[:4], tau, obs, cr) if heading is None
           else cone_model(q[:4], tau, obs, heading, cr))
    return ang, q[4] * doppler_factor(q[:4], tau, obs, obs_vel, c, retarded=bool(cr))


def _jacobian(q: np.ndarray, tau: np.ndarray, obs: np.ndarray, obs_vel: np.ndarray,
              heading: np.ndarray | None, c: float, cr: float | None = None) -> np.ndarray:
    """``∂[angles, frequencies]/∂[x, y, ẋ, ẏ, f0]`` (2B, 5), eq. (BF3)'s rows."""
    ja = bo_jacobian(q[:4], tau, obs, cr)
    if heading is not None:
        ja = np.sign(_wrap(bearing_model(q[:4], tau, obs, cr) - heading))[:, None] * ja
    jf = np.concatenate([-q[4] / c * range_rate_gradient(q[:4], tau, obs, obs_vel, cr),
                         doppler_factor(q[:4], tau, obs, obs_vel, c, bool(cr))[:, None]],
                        axis=1)
    return np.concatenate([np.concatenate([ja, np.zeros((tau.size, 1))], axis=1), jf])


def noise_scale(times: np.ndarray, values: np.ndarray) -> float:
    """Robust σ of the white noise on a smooth sequence from its second differences:
    ``1.4826 MAD(Δ²y) / √6`` (white noise of σ gives Δ² of variance 6σ²); the first guess of
    the weights when σ is not given."""
    v = np.asarray(values, float)[np.argsort(times, kind="stable")]
    d2 = np.diff(v, 2)
    return float(1.4826 * np.median(np.abs(d2 - np.median(d2))) / np.sqrt(6.0)) if d2.size \
        else 0.0


class _Fit:
    """The weighted residuals (eq. (BF1)) of one set of angle and frequency rows, their
    Jacobian, the population cost of the global search and the polish."""

    def __init__(self, tau: np.ndarray, ang: np.ndarray, f: np.ndarray, has_f: np.ndarray,
                 obs: np.ndarray, ov: np.ndarray, hd: np.ndarray | None, c: float,
                 retarded: bool, sig: list[float]) -> None:
        self.tau, self.ang, self.f, self.has_f = tau, ang, f, has_f
        self.obs, self.ov, self.hd, self.c = obs, ov, hd, c
        self.cr = c if retarded else None
        self.n, self.n_f = tau.size, int(has_f.sum())
        self.w = np.concatenate([np.full(self.n, 1.0 / sig[0]), has_f / sig[1]])
        self.white: tuple[Callable, Callable] | None = None  # C^{-1/2} of angles, frequencies
        self.estimates: tuple = ()  # their CorrelationEstimates (_correlated_refit)

    def weigh(self, sig: list[float]) -> None:
        """New standard deviations (angle, frequency) of the rows."""
        self.w[:self.n], self.w[self.n:] = 1.0 / sig[0], self.has_f / sig[1]

    def model(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return _model(q, self.tau, self.obs, self.ov, self.hd, self.c, self.cr)

    def _raw(self, q: np.ndarray) -> np.ndarray:
        """Angle residuals (rad) of every row, then frequency residuals (Hz, 0 where none)."""
        a, fm = self.model(q)
        ra = self.ang - a if self.hd is not None else _wrap(self.ang - a)
        return np.concatenate([ra, self.has_f * (self.f - fm)])

    def unweighted(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Angle residuals (rad) of every row, frequency residuals (Hz) of the rows with one."""
        r, n = self._raw(q), self.n
        return r[:n], r[n:][self.has_f]

    def res(self, q: np.ndarray) -> np.ndarray:
        """The weighted residuals: divided by σ (eq. (BF1)), or, with ``white`` set,
        whitened under the correlated errors fitted to each kind (module doc)."""
        if self.white is None:
            return self.w * self._raw(q)
        ra, rf = self.unweighted(q)
        return np.concatenate([self.white[0](ra), self.white[1](rf)])

    def model_jac(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Jacobian of the angle model (every row) and of the frequency model (rows with a
        frequency)."""
        j = _jacobian(q, self.tau, self.obs, self.ov, self.hd, self.c, self.cr)
        return j[:self.n], j[self.n:][self.has_f]

    def jac(self, q: np.ndarray) -> np.ndarray:
        if self.white is None:
            return -self.w[:, None] * _jacobian(q, self.tau, self.obs, self.ov, self.hd,
                                                self.c, self.cr)
        ja, jf = self.model_jac(q)
        return -np.concatenate([self.white[0](ja), self.white[1](jf)])

    def cost(self, q: np.ndarray) -> float:
        return float(np.sum(self.res(q) ** 2))

    def pop_cost(self, p: np.ndarray) -> np.ndarray:
        hd, n = self.hd, self.n
        return bf_cost_population(p, self.tau, self.obs, self.ov, self.ang,
                                  hd if hd is not None else self.ang, hd is not None,
                                  self.w[:n], self.f, self.w[n:], 1.0 / self.c)

    def polish(self, q0: np.ndarray) -> np.ndarray:
        return leastsq(self.res, q0, Dfun=self.jac, xtol=1e-12, ftol=1e-12, gtol=1e-12,
                       maxfev=200)[0]

    def solution(self, q: np.ndarray, sides: tuple[str, str], t0: float, t1: float,
                 o0: np.ndarray, n_in: int) -> TmaSolution:
        """The solution at ``q`` with its CRLB (the inverse FIM ``J^T J`` of the weighted
        residuals) and, for cone angles, the end ``sides`` it was searched on."""
        n, wj = self.n, self.jac(q)
        sol = finish_solution("bearings_frequency", t0, t1, q, self.res(q), wj, wj.T @ wj, o0,
                              np.concatenate(self.model(q)), n_used=n,
                              n_rejected=n_in - n, n_residuals=n + self.n_f)
        sol.rss = float(np.sum(self.unweighted(q)[0] ** 2))
        if sides[0]:
            sol.side = sides[0] if sides[0] == sides[1] else f"{sides[0]}>{sides[1]}"
        return sol


def _usable_rows(times, angle_rad, freq_hz, observer_xy, observer_vel, heading_rad,
                 outliers: bool, poly_degree: int, outlier_k: float) -> tuple:
    """The finite rows as arrays ``(t, angle, freq, obs, obs_vel, heading, n_in)``, after the
    polynomial-residue outlier rejection when ``outliers``: a rejected angle drops its row, a
    rejected frequency only its frequency (NaN); ``n_in`` counts the finite rows before."""
    t = np.asarray(times, float).reshape(-1)
    ang = np.asarray(angle_rad, float).reshape(-1)
    f = np.asarray(freq_hz, float).reshape(-1)
    obs = np.asarray(observer_xy, float).reshape(t.size, 2)
    ov = np.asarray(observer_vel, float).reshape(t.size, 2)
    hd = None if heading_rad is None else np.asarray(heading_rad, float).reshape(-1)
    ok = np.isfinite(ang) & np.isfinite(t)
    n_in = int(ok.sum())
    if outliers and n_in > poly_degree + 2:
        ok[ok] = reject_outliers(t[ok], np.cos(ang[ok]) if hd is not None
                                 else np.unwrap(ang[ok]), None, poly_degree, outlier_k)
        fin = ok & np.isfinite(f)
        if fin.sum() > poly_degree + 2:  # a rejected frequency leaves its row's angle
            f = f.copy()
            bad = np.flatnonzero(fin)[~reject_outliers(t[fin], f[fin], None, poly_degree,
                                                       outlier_k)]
            f[bad] = np.nan
    return (t[ok], ang[ok], f[ok], obs[ok], ov[ok], None if hd is None else hd[ok], n_in)


def _searched_state(pop_cost, search: PolarSearch, seed, popsize: int,
                    maxiter: int) -> np.ndarray:
    """The kinematic state ``[x, y, ẋ, ẏ]`` at the global minimum of ``pop_cost`` (a
    population cost of 5-parameter states, ``f0`` profiled out) over one search box,
    by differential evolution."""
    de = evolve(lambda q: pop_cost(search.to_state(q)), search.bounds, seed,
                popsize=popsize, maxiter=maxiter, tol=1e-3, mutation=(0.5, 1.0),
                recombination=0.9)
    return search.to_state(de.x.reshape(len(search.bounds), 1))[:, 0]


def _correlated_refit(fit: _Fit, found: dict, t: np.ndarray) -> tuple[dict, tuple]:
    """The generalised least-squares polish of every searched solution under errors fitted
    to the best one's residuals: per kind (angles, frequencies), an exponentially correlated
    error plus white noise (eq. (C4) of :mod:`.correlation`), its τ, σ and σ_w by the
    restricted likelihood given the fit's Jacobian (eq. (C5)), τ at most a quarter of the
    window (:func:`.correlation.window_bounds`); residuals and Jacobian are
    whitened by :func:`.correlation.correlated_whitener`. A bearing picked from a tonal whose
    amplitude and phase fluctuate over tens of seconds (a source's coherence time, the
    ownship's turn moving the beam pattern) has errors correlated over as long, which a
    white fit counts as independent: its bound is then too small by the square root of the
    rows per correlation time."""
    from .correlation import correlated_whitener, estimate_correlation_time, window_bounds

    best = min(found, key=lambda k: fit.cost(found[k]))
    ra, rf = fit.unweighted(found[best])
    ja, jf = fit.model_jac(found[best])
    tf = t[fit.has_f]
    fit.estimates = (estimate_correlation_time(t, ra, window_bounds(t), white=True,
                                               design=ja[:, :4]),  # angles do not see f0
                     estimate_correlation_time(tf, rf, window_bounds(tf), white=True,
                                               design=jf))
    fit.white = (correlated_whitener(t, fit.estimates[0]),
                 correlated_whitener(tf, fit.estimates[1]))
    found = {k: fit.polish(q) for k, q in found.items()}
    return found, min(found, key=lambda k: fit.cost(found[k]))


def solve_bearings_frequency(times: np.ndarray, angle_rad: np.ndarray, freq_hz: np.ndarray,
                             observer_xy: np.ndarray, observer_vel: np.ndarray,
                             sigma_rad: float | None, sigma_hz: float | None, *,
                             heading_rad: np.ndarray | None = None,
                             sound_speed: float = 1500.0, t0: float | None = None,
                             t1: float | None = None, min_range_m: float = 50.0,
                             max_range_m: float = 20000.0,
                             seed: int | np.random.Generator = 0, popsize: int = 20,
                             maxiter: int = 400, outliers: bool = False, poly_degree: int = 5,
                             outlier_k: float = 4.0, retarded: bool = False,
                             correlated: bool = False) -> TmaSolution:
    """Maximum-likelihood bearings + frequency TMA (module doc, eqs. (BF1)-(BF3)).

    Parameters
    ----------
    times : (B,) array_like
        s.
    angle_rad : (B,) array_like
        Bearings (rad clockwise from north), or cone angles when ``heading_rad`` is given.
    freq_hz : (B,) array_like
        Received frequency of the source's tonal (Hz); NaN for a row with an angle only
        (a broadband bearing), which then has no frequency term.
    observer_xy, observer_vel : (B, 2) array_like
        Array phase-centre positions (m) and velocities (m/s).
    sigma_rad, sigma_hz : float or None
        Angle and frequency standard deviations; None: estimated, each from the residuals of
        its own rows at the solution (first guess :func:`noise_scale`, then two re-weighted
        polishes).
    heading_rad : (B,) array_like, optional
        Array headings: the angles are a line array's cone angles, no side chosen (the
        search runs once per pair of end sides, as :func:`.bo_tma.solve_cone`).
    sound_speed : float
        m/s.
    t0, t1, min_range_m, max_range_m, seed, popsize, maxiter
        As :func:`.bo_tma.solve_bearings`.
    outliers, poly_degree, outlier_k
        Polynomial-residue outlier rejection (:func:`.bo_tma.reject_outliers`) of the angles
        (on ``cos θ`` for cone angles) and of the frequencies; a row is dropped when either is
        rejected.
    retarded : bool
        The source at its emission time in both kinds of rows (eq. (M5) of :mod:`.motion`:
        what arrives at ``t_b`` left the source ``R_b/c`` earlier), so that the state is the
        source's at ``t0``; the global search uses the reception-time model, the polish and
        the FIM the retarded one.
    correlated : bool
        After the white fit, the errors of each kind modelled as exponentially correlated
        plus white (:func:`.correlation.estimate_correlation_time`, restricted likelihood of
        its residuals, eq. (C5)) and the fit repeated by generalised least squares
        (:func:`_correlated_refit`); ``cov`` and ``crlb`` are then those of the correlated
        errors, and ``tau_s`` (``tau_sigma_s``) the angles' correlation time (its standard
        error).

    Returns
    -------
    TmaSolution
        ``method = "bearings_frequency"``; ``state`` is ``[x, y, ẋ, ẏ, f0]`` (m, m/s, Hz) at
        ``t0`` with the 5 × 5 ``cov`` and ``crlb``; for cone angles ``side``, ``cost_other``
        and ``mirror`` (the solution with both end sides flipped) as
        :func:`.bo_tma.solve_cone`.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(0.0, 600.0, 10.0)
    >>> obs = np.stack([np.where(t < 300, 0, 3 * (t - 300)), np.minimum(t, 300) * 3.0], 1)
    >>> vel = np.stack([np.where(t < 300, 0.0, 3.0), np.where(t < 300, 3.0, 0.0)], 1)
    >>> truth = np.array([2000.0, 1000.0, 0.0, 3.0, 300.0])
    >>> from arrayproc.track.batch.bf_tma import doppler_factor
    >>> from arrayproc.track.batch.bo_tma import bearing_model
    >>> brg = bearing_model(truth[:4], t, obs)
    >>> f = truth[4] * doppler_factor(truth[:4], t, obs, vel, 1500.0)
    >>> sol = solve_bearings_frequency(t, brg, f, obs, vel, 1e-3, 0.01, seed=1)
    >>> bool(np.allclose(sol.state, truth, rtol=1e-6))
    True
    """
    t, ang, f, obs, ov, hd, n_in = _usable_rows(times, angle_rad, freq_hz, observer_xy,
                                                observer_vel, heading_rad, outliers,
                                                poly_degree, outlier_k)
    has_f = np.isfinite(f)
    if t.size < 6 or has_f.sum() < 3:
        raise ValueError("bearings + frequency TMA needs at least 6 rows and 3 frequencies, "
                         f"{t.size} and {int(has_f.sum())} left")
    f = np.where(has_f, f, 0.0)        # rows without a frequency: weight 0 on it
    t0 = float(t[0] if t0 is None else t0)
    t1 = float(t[-1] if t1 is None else t1)
    o0, o1 = _observer_at(t, obs, t0), _observer_at(t, obs, t1)
    sig = [sigma_rad or max(noise_scale(t, ang if hd is not None else np.unwrap(ang)), 1e-5),
           sigma_hz or max(noise_scale(t[has_f], f[has_f]), 1e-6)]
    fit = _Fit(t - t0, ang, f, has_f, obs, ov, hd, float(sound_speed), retarded, sig)
    if hd is None:
        (b0, e0), (b1, e1) = end_value(t, ang, t0), end_value(t, ang, t1)
        searches = {("", ""): PolarSearch(b0, b1, max(np.deg2rad(2.0), 10 * e0, 10 * e1),
                                          min_range_m, max_range_m, t1 - t0, o0, o1)}
    else:
        searches = end_side_searches(t, ang, hd, t0, t1, o0, o1, min_range_m, max_range_m)
    found = {}
    for sides, search in searches.items():
        x = _searched_state(fit.pop_cost, search, seed, popsize, maxiter)
        g = doppler_factor(x, fit.tau, obs, ov, fit.c)
        found[sides] = fit.polish(np.append(x, np.sum(has_f * g * f)
                                            / np.sum(has_f * g * g)))  # eq. (BF2)
    best = min(found, key=lambda k: fit.cost(found[k]))
    for _ in range(2 if sigma_rad is None or sigma_hz is None else 0):
        ra, rf = fit.unweighted(found[best])         # the residuals of the best; the five
        if sigma_rad is None:                        # parameters shared by the two kinds
            sig[0] = max(float(np.sqrt(np.sum(ra**2) / max(fit.n - 2.5, 1.0))), 1e-9)
        if sigma_hz is None:
            sig[1] = max(float(np.sqrt(np.sum(rf**2) / max(fit.n_f - 2.5, 1.0))), 1e-9)
        fit.weigh(sig)
        found = {k: fit.polish(q) for k, q in found.items()}
        best = min(found, key=lambda k: fit.cost(found[k]))
    if correlated:
        found, best = _correlated_refit(fit, found, t)
    sol = fit.solution(found[best], best, t0, t1, o0, n_in)
    if correlated:
        sol.tau_s, sol.tau_sigma_s = fit.estimates[0].tau_s, fit.estimates[0].tau_sigma_s
    if hd is not None:
        flip = {"port": "starboard", "starboard": "port"}
        m = fit.solution(found[(flip[best[0]], flip[best[1]])], (flip[best[0]], flip[best[1]]),
                         t0, t1, o0, n_in)
        sol.cost_other, m.cost_other = m.cost, sol.cost
        sol.mirror = m
    return sol
