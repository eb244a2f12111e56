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
each end has two mirror bearings (``heading ∓ θ``, DESIGN section 3); with ``side = "auto"``
the choice at each end is a search coordinate (the source may cross the array's axis during
a manoeuvre), with ``port`` or ``starboard`` it is fixed for both ends.

An array that moves while the wavefront crosses it measures every delay scaled by
``1/(1 + V·u/c)`` (:mod:`.motion`, eq. (M1)); given the array's velocity, the delays are
brought back to the static delays the model (3.51) describes, ``τ (1 + V·u/c)`` (eq. (M2)),
with ``u`` the snapshot's plane-wave direction (for a line array its axial component
``cos θ`` only: the side is ambiguous, and a towed array moves along its axis).
"""

from __future__ import annotations

import numpy as np

from ._kernels import td_cost_population
from .fim import td_fim, td_jacobian
from .motion import axial_speed, emission_points, static_cone, static_delays
from .result import PolarSearch, TmaSolution, end_value, finish_solution, global_then_local

__all__ = ["delay_model", "plane_wave_directions", "solve_delays"]


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
    val = np.full(n_b, np.nan)
    hd = np.full(n_b, np.nan)
    far = n_h - 1 if ref != n_h - 1 else 0
    for b in range(n_b):
        ok = np.isfinite(y[b])
        ok[ref] = False
        if ok.sum() < 2:
            continue
        d = el[b, ok] - el[b, ref]
        rhs = -sound_speed * y[b, ok]
        if not line:
            u = np.linalg.lstsq(d, rhs, rcond=None)[0]
            val[b] = np.arctan2(u[0], u[1])
            continue
        if heading_rad is not None:
            hd[b] = float(np.asarray(heading_rad, float).reshape(-1)[b])
        else:
            a = el[b, ref] - el[b, far]
            hd[b] = np.arctan2(a[0], a[1])
        a = np.array([np.sin(hd[b]), np.cos(hd[b])])
        da = d @ a
        val[b] = np.arccos(np.clip(np.dot(da, rhs) / np.dot(da, da), -1.0, 1.0))
    return {"cone": val, "heading": hd} if line else {"bearing": val}


def solve_delays(times: np.ndarray, delays_s: np.ndarray, elements_xy: np.ndarray,
                 sigma_s: float | np.ndarray | None = None, *, ref: int = 0,
                 sound_speed: float = 1500.0, t0: float | None = None, t1: float | None = None,
                 side: str = "auto", heading_rad: np.ndarray | None = None,
                 array_velocity: np.ndarray | None = None, retarded: bool = False,
                 dz: np.ndarray | None = None, min_range_m: float = 50.0,
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
    min_range_m, max_range_m : float
        Range interval of the global search (m).
    seed : int or Generator
        Seed of the differential evolution.
    popsize, maxiter : int
        Differential-evolution settings.

    Returns
    -------
    TmaSolution
        ``method = "delays"``; ``fitted`` holds the model delays (B, N) (s).
    """
    t = np.asarray(times, float).reshape(-1)
    y = np.asarray(delays_s, float)
    elem = np.ascontiguousarray(np.asarray(elements_xy, float)[..., :2])
    if y.ndim != 2 or y.shape[0] != t.size or elem.shape[:2] != y.shape:
        raise ValueError(f"delays {y.shape} and elements {elem.shape} must be (B, N) and "
                         f"(B, N, 2) with B = {t.size}")
    t0 = float(t[0] if t0 is None else t0)
    t1 = float(t[-1] if t1 is None else t1)
    tau = t - t0
    sig = np.broadcast_to(np.asarray(1.0 if sigma_s is None else sigma_s, float), y.shape)
    use = np.isfinite(y) & np.isfinite(sig) & (sig > 0)
    use[:, ref] = False
    n_used = int(use.sum())
    if n_used < 5:
        raise ValueError(f"time-delay TMA needs at least 5 delays, {n_used} usable")
    w = np.where(use, 1.0 / np.where(use, sig, 1.0), 0.0)
    yz = np.where(use, y, 0.0)
    o0 = np.array([np.interp(t0, t, elem[:, ref, 0]), np.interp(t0, t, elem[:, ref, 1])])
    o1 = np.array([np.interp(t1, t, elem[:, ref, 0]), np.interp(t1, t, elem[:, ref, 1])])

    dzb = None if dz is None else np.broadcast_to(np.asarray(dz, float), y.shape)
    geo = dict(retarded=bool(retarded), dz=dzb)

    def res(x: np.ndarray) -> np.ndarray:
        return (w * (yz - delay_model(x, tau, elem, ref, sound_speed, **geo))).ravel()

    def jac(x: np.ndarray) -> np.ndarray:
        return -(w[..., None] * td_jacobian(x, tau, elem, ref, sound_speed, **geo)
                 ).reshape(-1, 4)

    if side not in ("auto", "port", "starboard"):
        raise ValueError(f"side must be auto, port or starboard, not {side!r}")
    pw = plane_wave_directions(np.where(use, y, np.nan), elem, ref, sound_speed, heading_rad)
    if array_velocity is not None:
        vel = np.asarray(array_velocity, float).reshape(t.size, 2)
        if "cone" in pw:
            v_ax = axial_speed(vel, np.nan_to_num(pw["heading"]))
            pw["cone"] = static_cone(pw["cone"], v_ax, sound_speed)
            v_u = v_ax * np.cos(pw["cone"])
        else:
            v_u = vel[:, 0] * np.sin(pw["bearing"]) + vel[:, 1] * np.cos(pw["bearing"])
        y = static_delays(y, np.nan_to_num(v_u), sound_speed)
        yz = np.where(use, y, 0.0)
    ends = []
    margin = np.deg2rad(2.0)
    for at in (t0, t1):
        if "bearing" in pw:
            v, sc = end_value(t, pw["bearing"], at)
            ends.append(np.array([v]))
        else:
            v, sc = end_value(t, pw["cone"], at)
            h = float(np.interp(at, t, np.unwrap(np.nan_to_num(pw["heading"]))))
            cands = {"port": h - v, "starboard": h + v}
            ends.append(np.array([cands[side]] if side != "auto" else list(cands.values())))
        margin = max(margin, 10 * sc)
    search = PolarSearch(ends[0], ends[1], margin, min_range_m, max_range_m, t1 - t0, o0, o1)
    ex = np.ascontiguousarray(elem[..., 0])
    ey = np.ascontiguousarray(elem[..., 1])
    wm = w * yz
    wc = w / sound_speed
    dz2 = np.zeros(y.shape) if dzb is None else np.ascontiguousarray(dzb**2)
    inv_c = 1.0 / sound_speed if retarded else 0.0
    x = global_then_local(
        lambda p: td_cost_population(p, tau, ex, ey, dz2, wm, wc, ref, inv_c), res, jac,
        search.bounds, search.to_state, seed, popsize=popsize, maxiter=maxiter)
    r = res(x)
    wj = jac(x)
    if sigma_s is None:  # one σ for all delays, from the residuals
        s = float(np.sqrt(np.sum(r**2) / max(n_used - 4, 1)))
        r, wj, sig_fim = r / s, wj / s, np.where(use, s, np.inf)
    else:
        sig_fim = np.where(use, sig, np.inf)
    fim = td_fim(x, tau, elem, ref, sound_speed, sig_fim, **geo)
    return finish_solution("delays", t0, t1, x, r, wj, fim, o0,
                           delay_model(x, tau, elem, ref, sound_speed, **geo), n_used=n_used)
