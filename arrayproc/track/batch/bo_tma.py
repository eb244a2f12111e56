"""Bearings-only batch TMA: Farina's maximum-likelihood estimator, thesis section 3.3.1.

State ``x = [x_T, y_T, ẋ_T, ẏ_T]`` at the window start (eq. (3.42)); the source moves at
constant velocity over the batch (eq. (3.41), with the measurement times in place of
``b T_B / N_B``); bearings ``h_b(x) = atan2(x_T + τ_b ẋ_T − x_o,b, y_T + τ_b ẏ_T − y_o,b)``
clockwise from north (eq. (3.44)); Gaussian errors give the log-likelihood (3.45)-(3.46) whose
maximum is the weighted least-squares minimum (3.47) of the wrapped residuals. As in the thesis
the minimum is found by differential evolution (then polished by least squares, see
:mod:`.result`), and outliers are removed first from the residues of a polynomial fitted to the
bearing sequence (the thesis's simplification of Farina's two-step rejection).

A line array measures a cone angle: the bearing is ``heading − θ`` (port) or ``heading + θ``
(starboard). :func:`solve_cone` fits the cone angle itself, ``θ_b = |wrap(h_b(x) − ψ_b)|``
(the nearer mirror of every row), so a source that crosses end-fire or changes side while the
ownship turns is fitted through it; it solves each pair of mirror sides at the window's ends
and reports the data's preferred solution with its mirror (the solution with both sides
flipped) and their cost difference. :func:`solve_line_bearings` with ``side="port"`` or
``"starboard"`` keeps one mirror for the whole window instead. A line array moving along its
axis at speed ``v`` measures the apparent cone angle ``cos θ_app = cos θ / (1 + (v/c) cos θ)``
(:mod:`.motion`, eq. (M3)); given ``v``, the cone angles are corrected first (eq. (M4)).
"""

from __future__ import annotations

import numpy as np

from ._kernels import bo_cost_population, cone_cost_population
from .fim import bo_fim, bo_jacobian
from .motion import emission_points, static_cone
from .result import PolarSearch, TmaSolution, end_value, finish_solution, global_then_local

__all__ = ["reject_outliers", "bearing_model", "cone_model", "end_side_searches",
           "solve_bearings", "solve_cone", "solve_line_bearings"]

#: ``cone`` (and its older name ``auto``): the side may change from row to row (:func:`solve_cone`)
SIDES = ("cone", "auto", "port", "starboard")
_SIGN = {"port": -1.0, "starboard": 1.0}


def reject_outliers(times: np.ndarray, values: np.ndarray, sigma: float | None = None,
                    degree: int = 5, k: float = 4.0, n_iter: int = 3) -> np.ndarray:
    """Outliers of a smooth sequence from the residues of a polynomial fit (thesis 3.3.1).

    A polynomial of ``degree`` (least squares, ``numpy.polynomial.Polynomial.fit``) is fitted
    to the kept samples; a sample is rejected when its residue exceeds ``k`` times the larger
    of ``sigma`` and the robust residue scale (1.4826 × median absolute residue); repeated
    ``n_iter`` times.

    Parameters
    ----------
    times : (B,) array_like
        Sample times (s).
    values : (B,) array_like
        Samples (e.g. unwrapped bearings, rad).
    sigma : float, optional
        Expected noise standard deviation (same unit as ``values``).
    degree, k, n_iter : int, float, int
        Fit degree, rejection threshold in standard deviations, passes.

    Returns
    -------
    (B,) bool ndarray
        True for the samples kept.
    """
    t = np.asarray(times, float)
    v = np.asarray(values, float)
    keep = np.isfinite(v) & np.isfinite(t)
    deg = int(min(degree, max(keep.sum() - 2, 0)))
    for _ in range(n_iter):
        if keep.sum() <= deg + 2:
            break
        poly = np.polynomial.Polynomial.fit(t[keep], v[keep], deg)
        res = v - poly(t)
        scale = 1.4826 * np.median(np.abs(res[keep]))
        thr = k * max(scale, sigma or 0.0)
        new = keep & (np.abs(res) <= thr) if thr > 0 else keep
        if np.array_equal(new, keep):
            break
        keep = new
    return keep


def bearing_model(state: np.ndarray, tau: np.ndarray, obs: np.ndarray,
                  sound_speed: float | None = None) -> np.ndarray:
    """Bearings ``h_b(x)`` (rad, clockwise from north) of thesis eq. (3.44).

    Parameters
    ----------
    state : (4,) array_like
        [x, y, vx, vy] at the window start (m, m/s).
    tau : (B,) array_like
        Times since the window start (s).
    obs : (B, 2) array_like
        Observer positions (m).
    sound_speed : float, optional
        m/s: the bearing of the source's emission point (eq. (M5) of :mod:`.motion`) rather
        than of its position at the measurement time (the thesis's model, None).

    Returns
    -------
    (B,) ndarray
    """
    x = np.asarray(state, float)
    tau = np.asarray(tau, float)
    if sound_speed:
        p = emission_points(x, tau, obs, sound_speed)[0]
    else:
        p = x[None, :2] + tau[:, None] * x[None, 2:]
    d = p - np.asarray(obs, float)
    return np.arctan2(d[:, 0], d[:, 1])


def _observer_at(t: np.ndarray, obs: np.ndarray, at: float) -> np.ndarray:
    """Observer position at time ``at``, linearly interpolated (held outside)."""
    return np.array([np.interp(at, t, obs[:, 0]), np.interp(at, t, obs[:, 1])])


def _wrap(a: np.ndarray) -> np.ndarray:
    return (a + np.pi) % (2 * np.pi) - np.pi


def solve_bearings(times: np.ndarray, bearings_rad: np.ndarray, observer_xy: np.ndarray,
                   sigma_rad: float | None = None, *, t0: float | None = None,
                   t1: float | None = None, min_range_m: float = 50.0,
                   max_range_m: float = 20000.0, seed: int | np.random.Generator = 0,
                   outliers: bool = True, poly_degree: int = 5, outlier_k: float = 4.0,
                   popsize: int = 20, maxiter: int = 400,
                   retarded_c: float | None = None) -> TmaSolution:
    """Maximum-likelihood bearings-only TMA (thesis eqs. (3.41)-(3.47)) with its CRLB (3.53).

    Parameters
    ----------
    times : (B,) array_like
        Bearing times (s).
    bearings_rad : (B,) array_like
        Measured bearings, rad clockwise from north.
    observer_xy : (B, 2) array_like
        Observer (array phase centre) positions at the bearing times (m).
    sigma_rad : float, optional
        Bearing standard deviation (rad); estimated from the residuals when None.
    t0, t1 : float, optional
        Window start (the state's time) and end (s); default the first and last time.
    min_range_m, max_range_m : float
        Range interval of the global search at the window's start and end (m).
    seed : int or Generator
        Seed of the differential evolution.
    outliers : bool
        Reject outliers from a polynomial fit first.
    poly_degree, outlier_k : int, float
        Polynomial degree and threshold (in σ) of the rejection.
    popsize, maxiter : int
        Differential-evolution settings.
    retarded_c : float, optional
        Sound speed (m/s) to model the source at its emission time (eq. (M5) of
        :mod:`.motion`); None: the thesis's model (3.44).

    Returns
    -------
    TmaSolution
        ``method = "bearings"``; ``fitted`` holds the model bearings (rad) of the kept samples.

    Examples
    --------
    An observer at 5 m/s north for 300 s, then east, and a target starting at (4000, 3000) m
    on (−3, 1) m/s; noiseless bearings every 10 s give back the target's state at ``t0``:

    >>> import numpy as np
    >>> from arrayproc.track.batch import solve_bearings
    >>> t = np.arange(0.0, 600.0, 10.0)
    >>> observer = np.where(t[:, None] < 300.0, [0.0, 5.0] * t[:, None],
    ...                     [0.0, 1500.0] + [5.0, 0.0] * (t[:, None] - 300.0))
    >>> d = [4000.0, 3000.0] + [-3.0, 1.0] * t[:, None] - observer
    >>> sol = solve_bearings(t, np.arctan2(d[:, 0], d[:, 1]), observer, np.radians(0.5),
    ...                      seed=1, popsize=8, maxiter=50, outliers=False)
    >>> np.round(sol.state, 1).tolist()  # x, y (m), vx, vy (m/s)
    [4000.0, 3000.0, -3.0, 1.0]
    >>> round(sol.speed_mps, 2), sol.n_used
    (3.16, 60)
    """
    t = np.asarray(times, float).reshape(-1)
    y = np.asarray(bearings_rad, float).reshape(-1)
    obs = np.asarray(observer_xy, float).reshape(t.size, 2)
    t0 = float(t[0] if t0 is None else t0)
    t1 = float(t[-1] if t1 is None else t1)
    keep = (reject_outliers(t, np.unwrap(y), sigma_rad, poly_degree, outlier_k) if outliers
            else np.isfinite(y))
    t, y, obs, n_rej = t[keep], y[keep], obs[keep], int((~keep).sum())
    if t.size < 5:
        raise ValueError(f"bearings-only TMA needs at least 5 bearings, {t.size} left")
    tau = t - t0
    o0 = _observer_at(t, obs, t0)
    o1 = _observer_at(t, obs, t1)
    w = np.full(t.size, 1.0 / (sigma_rad if sigma_rad else 1.0))

    cr = float(retarded_c) if retarded_c else None
    inv_c = 1.0 / cr if cr else 0.0

    def res(x: np.ndarray) -> np.ndarray:
        return w * _wrap(y - bearing_model(x, tau, obs, cr))

    def jac(x: np.ndarray) -> np.ndarray:
        return -w[:, None] * bo_jacobian(x, tau, obs, cr)

    (b0, s0), (b1, s1) = end_value(t, y, t0), end_value(t, y, t1)
    search = PolarSearch(b0, b1, max(np.deg2rad(2.0), 10 * s0, 10 * s1), min_range_m,
                         max_range_m, t1 - t0, o0, o1)
    x = global_then_local(lambda p: bo_cost_population(p, tau, obs, y, w, inv_c), res, jac,
                          search.bounds, search.to_state, seed, popsize=popsize,
                          maxiter=maxiter)
    r = res(x)
    rss = float(np.sum((r / w) ** 2))
    sig = sigma_rad if sigma_rad else float(np.sqrt(rss / max(t.size - 4, 1)))
    if not sigma_rad:  # re-weight with the estimated σ
        r, w[:] = r / sig, 1.0 / sig
    sol = finish_solution("bearings", t0, t1, x, r, jac(x), bo_fim(x, tau, obs, sig, cr), o0,
                          bearing_model(x, tau, obs, cr), n_used=t.size, n_rejected=n_rej)
    sol.rss = rss
    return sol


def cone_model(state: np.ndarray, tau: np.ndarray, obs: np.ndarray, heading: np.ndarray,
               sound_speed: float | None = None) -> np.ndarray:
    """Cone angles ``|wrap(h_b(x) − ψ_b)|`` (rad, 0 forward end-fire) of the bearings of eq.
    (3.44) on a line array of heading ``ψ_b`` (rad): the angle between the array's axis and
    the line of sight, whichever side the source is on."""
    return np.abs(_wrap(bearing_model(state, tau, obs, sound_speed) - np.asarray(heading)))


def _cone_setup(t: np.ndarray, cone: np.ndarray, heading: np.ndarray, obs: np.ndarray,
                t0: float | None, t1: float | None, sigma_rad: float | None, outliers: bool,
                poly_degree: int, outlier_k: float) -> tuple:
    """Rows kept (outliers judged on cos θ, smooth through end-fire), window ends, observer
    at the ends and the weights."""
    t0 = float(t[0] if t0 is None else t0)
    t1 = float(t[-1] if t1 is None else t1)
    keep = (reject_outliers(t, np.cos(cone), None, poly_degree, outlier_k) if outliers
            else np.isfinite(cone))
    n_rej = int((~keep).sum())
    t, cone, heading, obs = t[keep], cone[keep], heading[keep], obs[keep]
    if t.size < 5:
        raise ValueError(f"bearings-only TMA needs at least 5 bearings, {t.size} left")
    w = np.full(t.size, 1.0 / (sigma_rad if sigma_rad else 1.0))
    return t, cone, heading, obs, t0, t1, n_rej, w


def end_side_searches(t: np.ndarray, cone: np.ndarray, heading: np.ndarray, t0: float,
                      t1: float, o0: np.ndarray, o1: np.ndarray, min_range_m: float,
                      max_range_m: float) -> dict[tuple[str, str], PolarSearch]:
    """One global search box per pair of mirror sides (start, end) of a line array's cone
    angles: the bearings ``ψ ∓ θ`` of each side extrapolated to the window's ends."""
    out = {}
    for s0 in ("starboard", "port"):
        for s1 in ("starboard", "port"):
            (b0, e0) = end_value(t, heading + _SIGN[s0] * cone, t0)
            (b1, e1) = end_value(t, heading + _SIGN[s1] * cone, t1)
            out[(s0, s1)] = PolarSearch(b0, b1, max(np.deg2rad(2.0), 10 * e0, 10 * e1),
                                        min_range_m, max_range_m, t1 - t0, o0, o1)
    return out


def solve_cone(times: np.ndarray, cone_rad: np.ndarray, heading_rad: np.ndarray,
               observer_xy: np.ndarray, sigma_rad: float | None = None, *,
               t0: float | None = None, t1: float | None = None, min_range_m: float = 50.0,
               max_range_m: float = 20000.0, seed: int | np.random.Generator = 0,
               outliers: bool = True, poly_degree: int = 5, outlier_k: float = 4.0,
               popsize: int = 20, maxiter: int = 400, retarded_c: float | None = None
               ) -> TmaSolution:
    """Maximum-likelihood bearings-only TMA of a line array's cone angles, no side chosen.

    The residual of row ``b`` is ``θ_b − |wrap(h_b(x) − ψ_b)|`` (:func:`cone_model`; thesis
    eqs. (3.44), (3.47) with the bearing folded onto the array's axis), so the source may
    cross end-fire or change side within the window. Its FIM is that of the bearings
    (:func:`.fim.bo_fim`): each row of the cone Jacobian is ± the bearing row. The global
    search runs once for each pair of mirror sides at the window's start and end (the
    source's side there), and the least-cost solution is kept.

    Parameters
    ----------
    times : (B,) array_like
        s.
    cone_rad : (B,) array_like
        Cone angles (rad, 0 forward end-fire, π aft).
    heading_rad : (B,) array_like
        Array heading at each time (rad clockwise from north).
    observer_xy : (B, 2) array_like
        Array phase-centre positions (m).
    sigma_rad : float, optional
        Cone-angle standard deviation (rad); estimated from the residuals when None.
    t0, t1, min_range_m, max_range_m, seed, outliers, poly_degree, outlier_k, popsize, \
maxiter, retarded_c
        As :func:`solve_bearings` (outliers are judged on ``cos θ``).

    Returns
    -------
    TmaSolution
        ``method = "bearings"``; ``side`` names the source's side at the window's start and
        end (``starboard``, ``port``, ``starboard>port`` …); ``cost_other`` is the cost of the
        mirror solution (both sides flipped), whose whole solution is in ``mirror``; their
        difference (in units of χ², with σ given or estimated) says how strongly the data
        prefer the solution kept. ``fitted`` holds the model cone angles (rad).
    """
    t = np.asarray(times, float).reshape(-1)
    t, cone, hd, obs, t0, t1, n_rej, w = _cone_setup(
        t, np.asarray(cone_rad, float).reshape(-1), np.asarray(heading_rad, float).reshape(-1),
        np.asarray(observer_xy, float).reshape(t.size, 2), t0, t1, sigma_rad, outliers,
        poly_degree, outlier_k)
    tau = t - t0
    o0, o1 = _observer_at(t, obs, t0), _observer_at(t, obs, t1)
    cr = float(retarded_c) if retarded_c else None
    inv_c = 1.0 / cr if cr else 0.0

    def res(x: np.ndarray) -> np.ndarray:
        return w * (cone - cone_model(x, tau, obs, hd, cr))

    def jac(x: np.ndarray) -> np.ndarray:
        sign = np.sign(_wrap(bearing_model(x, tau, obs, cr) - hd))
        return -(w * sign)[:, None] * bo_jacobian(x, tau, obs, cr)

    found = {}
    for sides, search in end_side_searches(t, cone, hd, t0, t1, o0, o1, min_range_m,
                                           max_range_m).items():
        found[sides] = global_then_local(
            lambda p: cone_cost_population(p, tau, obs, cone, hd, w, inv_c), res, jac,
            search.bounds, search.to_state, seed, popsize=popsize, maxiter=maxiter)
    rss = {k: float(np.sum((res(x) / w) ** 2)) for k, x in found.items()}
    best = min(rss, key=rss.get)
    flip = {"port": "starboard", "starboard": "port"}
    mirror = (flip[best[0]], flip[best[1]])
    sig = sigma_rad if sigma_rad else float(np.sqrt(rss[best] / max(t.size - 4, 1)))
    w[:] = 1.0 / sig
    sols = {}
    for k in (best, mirror):
        x = found[k]
        sol = finish_solution("bearings", t0, t1, x, res(x), jac(x),
                              bo_fim(x, tau, obs, sig, cr), o0, cone_model(x, tau, obs, hd, cr),
                              n_used=t.size, n_rejected=n_rej)
        sol.rss = rss[k]
        sol.side = k[0] if k[0] == k[1] else f"{k[0]}>{k[1]}"
        sols[k] = sol
    sols[best].cost_other = sols[mirror].cost
    sols[mirror].cost_other = sols[best].cost
    sols[best].mirror = sols[mirror]
    return sols[best]


def solve_line_bearings(times: np.ndarray, cone_rad: np.ndarray, heading_rad: np.ndarray,
                        observer_xy: np.ndarray, sigma_rad: float | None = None,
                        side: str = "auto", axial_speed_mps: np.ndarray | None = None,
                        sound_speed: float = 1500.0, **kw: object) -> TmaSolution:
    """Bearings-only TMA from a line array's cone angles, resolving the mirror ambiguity.

    Parameters
    ----------
    times : (B,) array_like
        s.
    cone_rad : (B,) array_like
        Cone angles (rad, 0 forward end-fire).
    heading_rad : (B,) array_like
        Array heading at each time (rad clockwise from north).
    observer_xy : (B, 2) array_like
        Array phase-centre positions (m).
    sigma_rad : float, optional
        Bearing (cone) standard deviation (rad).
    side : {"cone", "auto", "port", "starboard"}
        ``cone`` (or ``auto``): fit the cone angles themselves, the side free to change from
        row to row (:func:`solve_cone`); ``port`` / ``starboard``: one mirror for the whole
        window, bearing ``heading − θ`` or ``heading + θ``.
    axial_speed_mps : float or (B,) array_like, optional
        The array's speed along its axis (forward positive, m/s) at each time; when given,
        the cone angles are corrected for the array's motion during the wavefront's passage,
        ``cos θ = cos θ_app / (1 − (v/c) cos θ_app)`` (:mod:`.motion`, eq. (M4)).
    sound_speed : float
        m/s (used by the motion correction).
    **kw
        Passed to :func:`solve_bearings`.

    Returns
    -------
    TmaSolution
        With ``side``; for ``cone``, ``cost_other`` and ``mirror`` (:func:`solve_cone`).
    """
    if side not in SIDES:
        raise ValueError(f"side must be one of {SIDES}, not {side!r}")
    cone = np.asarray(cone_rad, float)
    if axial_speed_mps is not None:
        cone = static_cone(cone, axial_speed_mps, sound_speed)
    hd = np.asarray(heading_rad, float)
    if side in ("cone", "auto"):
        return solve_cone(times, cone, hd, observer_xy, sigma_rad, **kw)
    sol = solve_bearings(times, hd + _SIGN[side] * cone, observer_xy, sigma_rad, **kw)
    sol.side = side
    return sol
