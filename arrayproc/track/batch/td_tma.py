"""Time-delay batch TMA, thesis section 3.3.2.

The measurements are every hydrophone's delay to the reference hydrophone in every snapshot
(eqs. (3.48)-(3.50), the matrix collapsed with ``m = n + (b − 1) N_H``); the model is the
difference of the source's ranges to the two hydrophones divided by the sound speed
(eq. (3.51)), with the element positions of each snapshot's pose (the array need not be
straight, nor the same from one snapshot to the next); the source moves at constant velocity
from the state at the window start (eq. (3.41)). The maximum-likelihood estimate maximises the
Gaussian log-likelihood (3.52), i.e. minimises the weighted sum of squared delay residuals,
found as for bearings-only TMA by differential evolution and a least-squares polish
(:mod:`.result`). Each delay may carry its own σ (the ``sigma`` column of a ``delays``
product); missing delays (NaN) are left out.

The global search is bounded around the bearings at the window's two ends (see
:mod:`.result`), taken from the plane-wave directions that fit each snapshot's delays best
(least squares, ``τ_n ≈ −(e_n − e_ref)·u / c``). A line array gives the cone angle only, so
each end has two mirror bearings (``heading ∓ θ``, docs/architecture.md); with ``side = "auto"``
the choice at each end is a search coordinate (the source may cross the array's axis during
a manoeuvre), with ``port`` or ``starboard`` it is fixed for both ends.

An array that moves while the wavefront crosses it measures every delay scaled by
``1/(1 + V·u/c)`` (:mod:`.motion`, eq. (M1)); given the array's velocity, the delays are
brought back to the static delays the model (3.51) describes, ``τ (1 + V·u/c)`` (eq. (M2)),
with ``u`` the snapshot's plane-wave direction (for a line array its axial component
``cos θ`` only: the side is ambiguous, and a towed array moves along its axis).

Correlated delay errors: every delay of a snapshot is measured against the same reference
hydrophone (generalised cross-correlation, eq. (3.48)), so the reference's noise is common to
all of them: ``τ_n = (t_n + ε_n) − (t_ref + ε_ref)`` has the within-snapshot correlation
``ρ = σ_ref² / (σ_n² + σ_ref²)`` (½ for equal noise; 0.35 measured on the simulated towed
recording, docs/validation/batch_tma.md). The thesis's likelihood (3.52) takes the delays as
independent; with ``correlation = ρ`` the covariance of a snapshot's delays becomes
``C_b = S((1 − ρ) I + ρ 11ᵀ)S`` (``S`` the σ's), whose inverse is closed-form,

    C_b⁻¹ = S⁻¹ (I − γ_b 11ᵀ) S⁻¹ / (1 − ρ),   γ_b = ρ / (1 − ρ + n_b ρ)               (D1)

(``n_b`` the delays used in the snapshot), so the weighted residuals and Jacobian are
whitened per snapshot by ``L_b = (I − β_b 11ᵀ)/√(1 − ρ)``, ``β_b = (1 − √(1 − n_b γ_b))/n_b``
(``L_bᵀ L_b = C_b⁻¹``), and the FIM (3.53) becomes ``Σ_b G_bᵀ C_b⁻¹ G_b``. With
``correlation = None`` ρ is estimated from the residuals of the independent-error fit,
``ρ̂ = Σ_b [(Σ_n r)² − Σ_n r²] / Σ_b (n_b − 1) Σ_n r²`` (r the σ-normalised residuals), and
the solution is polished again with it. The global search keeps the independent-error cost
(its minimum lies within a few σ of the correlated one).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from ._kernels import td_cost_population, td_model_jacobian
from .motion import axial_speed, emission_points, static_cone, static_delays
from .result import PolarSearch, TmaSolution, end_value, finish_solution, global_then_local

__all__ = ["delay_model", "plane_wave_directions", "solve_delays", "estimate_correlation",
           "SnapshotWhitening"]


def delay_model(state: np.ndarray, tau: np.ndarray, elem: np.ndarray, ref: int,
                sound_speed: float, retarded: bool = False,
                dz: np.ndarray | None = None) -> np.ndarray:
    """Delays ``h_bn(x)`` of thesis eq. (3.51) (s), arrival at element n minus at ``ref``.

    Parameters
    ----------
    state : (4,) array_like
        [x, y, vx, vy] at the window start (m, m/s).
    tau : (B,) array_like
        Snapshot times since the window start (s).
    elem : (B, N, 2) array_like
        Element positions, world frame (m).
    ref : int
        Reference element.
    sound_speed : float
        m/s.
    retarded : bool
        Source at the emission time of what the reference element receives at ``τ_b``
        (eq. (M5) of :mod:`.motion`); False: at ``τ_b`` (the thesis's model).
    dz : (B, N) array_like, optional
        Depth differences element − source (m): ranges ``√(d_h² + Δz²)``; None: planar.

    Returns
    -------
    (B, N) ndarray
    """
    x = np.asarray(state, float)
    tau = np.asarray(tau, float)
    el = np.asarray(elem, float)[..., :2]
    dz2 = np.zeros(el.shape[:2]) if dz is None else np.asarray(dz, float) ** 2
    if retarded:
        p = emission_points(x, tau, el[:, ref], sound_speed, dz2[:, ref])[0]
    else:
        p = x[None, :2] + tau[:, None] * x[None, 2:]
    d = p[:, None, :] - el
    r = np.sqrt(np.sum(d * d, -1) + dz2)
    return (r - r[:, ref:ref + 1]) / sound_speed


def plane_wave_directions(delays_s: np.ndarray, elements_xy: np.ndarray, ref: int,
                          sound_speed: float, heading_rad: np.ndarray | None = None
                          ) -> dict[str, np.ndarray]:
    """Per-snapshot plane-wave directions that fit the delays best (least squares).

    Parameters
    ----------
    delays_s : (B, N) array_like
        Delays to the reference element (s), NaN where missing.
    elements_xy : (B, N, 2) array_like
        Element positions (m).
    ref : int
        Reference element.
    sound_speed : float
        m/s.
    heading_rad : (B,) array_like, optional
        Forward direction of a line array (rad); default from the last element to the
        reference.

    Returns
    -------
    dict
        2-D array: ``{"bearing": (B,)}`` rad clockwise from north. Line array:
        ``{"cone": (B,), "heading": (B,)}`` (rad; the mirror bearings are
        ``heading ∓ cone``). NaN where a snapshot has fewer than two delays.
    """
    y = np.asarray(delays_s, float)
    el = np.asarray(elements_xy, float)[..., :2]
    n_b, n_h = y.shape
    d0 = el[0] - el[0, ref]
    sv = np.linalg.svd(d0 - d0.mean(0), compute_uv=False)
    line = sv.size < 2 or sv[1] <= 1e-6 * max(sv[0], 1e-300)
    ok = np.isfinite(y)
    ok[:, ref] = False
    enough = ok.sum(1) >= 2
    d = np.where(ok[..., None], el - el[:, ref:ref + 1], 0.0)            # (B, N, 2)
    rhs = np.where(ok, -sound_speed * np.where(ok, y, 0.0), 0.0)          # (B, N)
    with np.errstate(invalid="ignore", divide="ignore"):
        if not line:   # least squares d·u = −c τ per snapshot (2 × 2 normal equations)
            a = np.einsum("bni,bnj->bij", d, d)
            u = np.einsum("bij,bj->bi", np.linalg.pinv(a), np.einsum("bni,bn->bi", d, rhs))
            return {"bearing": np.where(enough, np.arctan2(u[:, 0], u[:, 1]), np.nan)}
        if heading_rad is not None:
            hd = np.asarray(heading_rad, float).reshape(-1).copy()
        else:
            far = n_h - 1 if ref != n_h - 1 else 0
            ax = el[:, ref] - el[:, far]
            hd = np.arctan2(ax[:, 0], ax[:, 1])
        da = d[..., 0] * np.sin(hd)[:, None] + d[..., 1] * np.cos(hd)[:, None]
        cone = np.arccos(np.clip(np.sum(da * rhs, 1) / np.sum(da * da, 1), -1.0, 1.0))
    return {"cone": np.where(enough, cone, np.nan), "heading": np.where(enough, hd, np.nan)}


def solve_delays(times: np.ndarray, delays_s: np.ndarray, elements_xy: np.ndarray,
                 sigma_s: float | np.ndarray | None = None, *, ref: int = 0,
                 sound_speed: float = 1500.0, t0: float | None = None, t1: float | None = None,
                 side: str = "auto", heading_rad: np.ndarray | None = None,
                 array_velocity: np.ndarray | None = None, retarded: bool = False,
                 dz: np.ndarray | None = None, correlation: float | None = 0.0,
                 min_range_m: float = 50.0,
                 max_range_m: float = 20000.0, seed: int | np.random.Generator = 0,
                 popsize: int = 20, maxiter: int = 400) -> TmaSolution:
    """Maximum-likelihood time-delay TMA (thesis eqs. (3.48)-(3.52)) with its CRLB (C.12).

    Parameters
    ----------
    times : (B,) array_like
        Snapshot times (s).
    delays_s : (B, N) array_like
        Delay of each element to the reference (s); NaN where missing.
    elements_xy : (B, N, 2) array_like
        Element positions in the world frame at each snapshot (m).
    sigma_s : float or (B, N) array_like, optional
        Delay standard deviation (s); estimated from the residuals when None.
    ref : int
        Reference element (its delays are ignored).
    sound_speed : float
        m/s.
    t0, t1 : float, optional
        Window start (the state's time) and end (s).
    side : {"auto", "port", "starboard"}
        Mirror bearings searched for a line array (ignored for a 2-D array).
    heading_rad : (B,) array_like, optional
        Array heading at each snapshot (rad), naming the sides.
    array_velocity : (B, 2) array_like, optional
        The array's velocity through the water at each snapshot (m/s, east/north); when
        given, the delays are corrected for the array's motion during the wavefront's passage
        (:mod:`.motion`, eqs. (M2), (M4)) before the fit.
    retarded : bool
        Model the source at its emission time (eq. (M5) of :mod:`.motion`).
    dz : (B, N) array_like, optional
        Depth differences element − source (m) for the ranges ``√(d_h² + Δz²)``; None: the
        planar model.
    correlation : float or None
        Correlation ρ in [0, 1) of the delays of one snapshot (common reference, eq. (D1));
        0: independent errors (the thesis's model); None: estimated from the residuals.
    min_range_m, max_range_m : float
        Range interval of the global search (m).
    seed : int or Generator
        Seed of the differential evolution.
    popsize, maxiter : int
        Differential-evolution settings.

    Returns
    -------
    TmaSolution
        ``method = "delays"``; ``fitted`` holds the model delays (B, N) (s);
        ``correlation`` the ρ used.
    """
    t = np.asarray(times, float).reshape(-1)
    y = np.asarray(delays_s, float)
    elem = np.ascontiguousarray(np.asarray(elements_xy, float)[..., :2])
    if y.ndim != 2 or y.shape[0] != t.size or elem.shape[:2] != y.shape:
        raise ValueError(f"delays {y.shape} and elements {elem.shape} must be (B, N) and "
                         f"(B, N, 2) with B = {t.size}")
    t0 = float(t[0] if t0 is None else t0)
    t1 = float(t[-1] if t1 is None else t1)
    sig = np.broadcast_to(np.asarray(1.0 if sigma_s is None else sigma_s, float), y.shape)
    use = np.isfinite(y) & np.isfinite(sig) & (sig > 0)
    use[:, ref] = False
    n_used = int(use.sum())
    if n_used < 5:
        raise ValueError(f"time-delay TMA needs at least 5 delays, {n_used} usable")
    w = np.where(use, 1.0 / np.where(use, sig, 1.0), 0.0)
    o0 = np.array([np.interp(t0, t, elem[:, ref, 0]), np.interp(t0, t, elem[:, ref, 1])])
    o1 = np.array([np.interp(t1, t, elem[:, ref, 0]), np.interp(t1, t, elem[:, ref, 1])])
    dzb = None if dz is None else np.broadcast_to(np.asarray(dz, float), y.shape)
    dz2 = np.zeros(y.shape) if dzb is None else np.ascontiguousarray(dzb**2)

    if side not in ("auto", "port", "starboard"):
        raise ValueError(f"side must be auto, port or starboard, not {side!r}")
    pw = plane_wave_directions(np.where(use, y, np.nan), elem, ref, sound_speed, heading_rad)
    if array_velocity is not None:
        y = _motion_corrected(y, pw, array_velocity, sound_speed)
    fit = _DelayResiduals(t - t0, elem, dz2, ref, sound_speed, retarded, w,
                          np.where(use, y, 0.0))
    ends, margin = _search_ends(t, pw, (t0, t1), side)
    search = PolarSearch(ends[0], ends[1], margin, min_range_m, max_range_m, t1 - t0, o0, o1)
    wm = w * fit.yz
    wc = w / sound_speed
    inv_c = 1.0 / sound_speed if retarded else 0.0
    x = global_then_local(
        lambda p: td_cost_population(p, fit.tau, fit.ex, fit.ey, dz2, wm, wc, ref, inv_c),
        fit.res, fit.jac, search.bounds, search.to_state, seed, popsize=popsize,
        maxiter=maxiter)
    x, r, wj, rho = _correlated_refit(fit, x, use, correlation)
    if sigma_s is None:  # one σ for all delays, from the residuals
        s = float(np.sqrt(np.sum(r**2) / max(n_used - 4, 1)))
        r, wj = r / s, wj / s
    # eq. (3.53): the whitened Jacobian's Gram matrix, Σ_b G_bᵀ C_b⁻¹ G_b
    fim = wj.T @ wj
    sol = finish_solution("delays", t0, t1, x, r, wj, fim, o0, fit.model(x)[0].copy(),
                          n_used=n_used)
    sol.correlation = rho
    return sol


class _DelayResiduals:
    """Weighted residuals w (y − h(x)) of eq. (3.50) and their Jacobian, with the model
    (h, ∂h/∂x) at the last x kept for the Jacobian call that follows the residual call."""

    def __init__(self, tau: np.ndarray, elem: np.ndarray, dz2: np.ndarray, ref: int,
                 sound_speed: float, retarded: bool, w: np.ndarray, yz: np.ndarray) -> None:
        self.tau, self.dz2, self.ref, self.c = tau, dz2, ref, sound_speed
        self.ex = np.ascontiguousarray(elem[..., 0])
        self.ey = np.ascontiguousarray(elem[..., 1])
        self.retarded, self.w, self.yz = bool(retarded), w, yz
        self.last: dict[str, np.ndarray] = {}

    def model(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(h, ∂h/∂x) at x."""
        last = self.last
        if "x" not in last or not np.array_equal(last["x"], x):
            last["x"] = np.array(x, float)
            last["h"], last["j"] = td_model_jacobian(last["x"], self.tau, self.ex, self.ey,
                                                     self.dz2, self.ref, self.c, self.retarded)
        return last["h"], last["j"]

    def res(self, x: np.ndarray) -> np.ndarray:
        return (self.w * (self.yz - self.model(x)[0])).ravel()

    def jac(self, x: np.ndarray) -> np.ndarray:
        return -(self.w[..., None] * self.model(x)[1]).reshape(-1, 4)


def _motion_corrected(y: np.ndarray, pw: dict, array_velocity: np.ndarray,
                      sound_speed: float) -> np.ndarray:
    """Delays corrected for the array's motion during the wavefront's passage (eqs. (M2),
    (M4) of :mod:`.motion`); a line array's cones in ``pw`` are made static in place."""
    vel = np.asarray(array_velocity, float).reshape(y.shape[0], 2)
    if "cone" in pw:
        v_ax = axial_speed(vel, np.nan_to_num(pw["heading"]))
        pw["cone"] = static_cone(pw["cone"], v_ax, sound_speed)
        v_u = v_ax * np.cos(pw["cone"])
    else:
        v_u = vel[:, 0] * np.sin(pw["bearing"]) + vel[:, 1] * np.cos(pw["bearing"])
    return static_delays(y, np.nan_to_num(v_u), sound_speed)


def _search_ends(t: np.ndarray, pw: dict, window: tuple[float, float],
                 side: str) -> tuple[list[np.ndarray], float]:
    """Candidate bearings (rad) at the window's two ends from the plane-wave directions (both
    mirror sides of a line array unless ``side`` names one) and the search margin (rad)."""
    ends = []
    margin = np.deg2rad(2.0)
    for at in window:
        if "bearing" in pw:
            v, sc = end_value(t, pw["bearing"], at)
            ends.append(np.array([v]))
        else:
            v, sc = end_value(t, pw["cone"], at)
            h = float(np.interp(at, t, np.unwrap(np.nan_to_num(pw["heading"]))))
            cands = {"port": h - v, "starboard": h + v}
            ends.append(np.array([cands[side]] if side != "auto" else list(cands.values())))
        margin = max(margin, 10 * sc)
    return ends, margin


def _correlated_refit(fit: _DelayResiduals, x: np.ndarray, use: np.ndarray,
                      correlation: float | None
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """The within-snapshot correlation ρ (given, or estimated from the residuals at x) and,
    for ρ > 0, the refit on the whitened residuals (eq. (D1)); (x, residuals, Jacobian, ρ)."""
    rho = 0.0 if correlation is None else float(correlation)
    if not 0.0 <= rho < 1.0:
        raise ValueError(f"correlation must be in [0, 1), not {rho}")
    shape = use.shape
    if correlation is None:
        rho = estimate_correlation(fit.res(x).reshape(shape), use)
    if rho <= 0.0:
        return x, fit.res(x), fit.jac(x), rho
    white = SnapshotWhitening(use, rho)
    x = least_squares(lambda q: white(fit.res(q).reshape(shape)).ravel(), x,
                      jac=lambda q: white(fit.jac(q).reshape(shape + (4,))).reshape(-1, 4),
                      method="lm", x_scale="jac", xtol=1e-12, ftol=1e-12, gtol=1e-12,
                      max_nfev=200).x
    r = white(fit.res(x).reshape(shape)).ravel()
    wj = white(fit.jac(x).reshape(shape + (4,))).reshape(-1, 4)
    return x, r, wj, rho


def estimate_correlation(resid: np.ndarray, use: np.ndarray) -> float:
    """Within-snapshot correlation of σ-normalised delay residuals (see the module docstring).

    Parameters
    ----------
    resid : (B, N) array_like
        Residuals divided by their σ (0 where unused).
    use : (B, N) bool array_like
        Delays used.

    Returns
    -------
    float
        ``ρ̂ = Σ_b [(Σ_n r)² − Σ_n r²] / Σ_b (n_b − 1) Σ_n r²``, clipped to [0, 0.95].
    """
    r = np.where(use, resid, 0.0)
    n = np.asarray(use).sum(1)
    s1, s2 = r.sum(1), (r * r).sum(1)
    den = float(np.sum((n - 1) * s2))
    return float(np.clip(np.sum(s1 * s1 - s2) / den, 0.0, 0.95)) if den > 0 else 0.0


class SnapshotWhitening:
    """``L_b = (I − β_b 11ᵀ)/√(1 − ρ)`` over the used delays of each snapshot (eq. (D1)).

    Parameters
    ----------
    use : (B, N) bool array_like
        Delays used (the others stay 0).
    rho : float
        Within-snapshot correlation, [0, 1).
    """

    def __init__(self, use: np.ndarray, rho: float) -> None:
        self.m = np.asarray(use, float)
        n = self.m.sum(1)
        gamma = rho / (1.0 - rho + n * rho)
        with np.errstate(invalid="ignore", divide="ignore"):
            beta = np.where(n > 0, (1.0 - np.sqrt(1.0 - n * gamma)) / np.maximum(n, 1), 0.0)
        self.beta = beta
        self.scale = 1.0 / np.sqrt(1.0 - rho)

    def __call__(self, a: np.ndarray) -> np.ndarray:
        """Whiten (B, N) or (B, N, k) σ-weighted residuals or Jacobian rows (0 where unused)."""
        a = np.asarray(a, float)
        m = self.m if a.ndim == 2 else self.m[..., None]
        b = self.beta[:, None] if a.ndim == 2 else self.beta[:, None, None]
        return (a - b * m * a.sum(1, keepdims=True)) * self.scale
