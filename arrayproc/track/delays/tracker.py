"""The recursive TDOA tracker's loop over rows of delays (thesis eqs. (3.37)-(3.40)): one
hypothesis bank (:class:`~arrayproc.track.manage.bank.HypothesisBank`: the mirror sides and
range priors of :func:`~arrayproc.track.delays.initial.initial_hypotheses`, gate, prune,
per-side estimate) fed one :class:`~arrayproc.track.models.tdoa.RowTDOA` model per row."""

from __future__ import annotations

from typing import Any

import numpy as np

from arrayproc.errors import ConfigError, FormatError
from arrayproc.track.delays.config import DELAYS_DEFAULTS, GAUSSIAN_FILTERS
from arrayproc.track.delays.initial import initial_hypotheses, motion_model
from arrayproc.track.filters import make_filter
from arrayproc.track.manage.bank import HypothesisBank
from arrayproc.track.models.tdoa import RowTDOA
from arrayproc.track.state import Context

__all__ = ["track_delays", "observer_states", "usable_delays"]


def _static_array_delays(y: np.ndarray, use: np.ndarray, el: np.ndarray, ref: int, c: float,
                         heading_rad: np.ndarray | None, vel: np.ndarray) -> np.ndarray:
    """Delays of a static array from a moving one's, τ (1 + V·u/c) (eqs. (M2), (M4) of
    :mod:`arrayproc.track.batch.motion`), u from each row's plane-wave fit (a line array's
    cone angle corrected by (M4) first, its axial component only)."""
    from arrayproc.track.batch.motion import axial_speed, static_cone, static_delays
    from arrayproc.track.batch.td_tma import plane_wave_directions

    pw = plane_wave_directions(np.where(use, y, np.nan), el[..., :2], ref, c, heading_rad)
    if "cone" in pw:
        v_ax = axial_speed(vel, np.nan_to_num(pw["heading"]))
        v_u = v_ax * np.cos(static_cone(pw["cone"], v_ax, c))
    else:
        v_u = vel[:, 0] * np.sin(pw["bearing"]) + vel[:, 1] * np.cos(pw["bearing"])
    return static_delays(y, np.nan_to_num(v_u), c)


def observer_states(times: np.ndarray, ref_xy: np.ndarray) -> np.ndarray:
    """Observer states [x, y, ẋ, ẏ] of the reference hydrophone: its positions and their
    time derivative (central differences; zero for one row)."""
    t = np.asarray(times, float)
    p = np.asarray(ref_xy, float)[:, :2]
    own = np.zeros((t.size, 4))
    own[:, :2] = p
    if t.size > 1:
        own[:, 2:] = np.gradient(p, t, axis=0)
    return own


def usable_delays(tau: np.ndarray, sigma: np.ndarray | None, corr: np.ndarray | None,
                  ref: int, d: dict[str, Any]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """σ of every delay (B, N), the usable delays (finite, σ > 0, ``corr`` ≥ ``min_corr``,
    not the reference) and the rows with at least two of them."""
    y = np.asarray(tau, float)
    B, N = y.shape
    if d["sigma_delay_s"] > 0:
        sig = np.full((B, N), float(d["sigma_delay_s"]))
    elif sigma is None:
        raise FormatError("delays: the product has no sigma column; set "
                          "tracker.delays.sigma_delay_s")
    else:
        sig = np.asarray(sigma, float)
    use = np.isfinite(y) & np.isfinite(sig) & (sig > 0)
    if corr is not None and d["min_corr"] > 0:
        use &= np.asarray(corr, float) >= d["min_corr"]
    use[:, ref] = False
    good = use.sum(1) >= 2
    if not good.any():
        raise FormatError("delays: no row has two usable delays")
    return sig, use, good


def _row_model(el: np.ndarray, use: np.ndarray, sig: np.ndarray, ref: int, sound_speed: float,
               d: dict[str, Any]) -> RowTDOA:
    """The TDOA model of one row: its usable elements and their σ (eqs. (3.38)-(3.39))."""
    keep = use.copy()
    keep[ref] = True
    idx = np.flatnonzero(keep)
    return RowTDOA(elements=el[idx] - el[ref], reference=int(np.searchsorted(idx, ref)),
                   sound_speed=sound_speed, sigma_s=float(sig[use].min()),
                   sigma_row=sig[use], source_dz_m=float(d["source_dz_m"]))


def track_delays(times: np.ndarray, tau: np.ndarray, sigma: np.ndarray | None,
                 elements: np.ndarray, ref: int, sound_speed: float, d: dict[str, Any],
                 filter_name: str = "ukf", filter_params: dict[str, Any] | None = None,
                 heading_rad: np.ndarray | None = None, corr: np.ndarray | None = None,
                 array_velocity: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Recursive position estimate from rows of delays (thesis eqs. (3.37)-(3.40)).

    Parameters
    ----------
    times : (B,) array
        Row times (s), increasing.
    tau : (B, N) array
        Delay of each element to the reference (s), NaN where missing.
    sigma : (B, N) array or None
        σ of each delay (s); None or NaN where ``d["sigma_delay_s"]`` must serve.
    elements : (B, N, 3) array
        World positions of the elements at each row (m; x east, y north, z down).
    ref : int
        Reference element.
    sound_speed : float
        m/s.
    d : dict
        The ``delays`` settings (:data:`DELAYS_DEFAULTS`; missing keys take the defaults).
    filter_name : str
        ``ekf``, ``ukf``, ``ckf`` or ``ghf``.
    filter_params : dict, optional
        The filter's parameters.
    heading_rad : (B,) array, optional
        Array headings (rad) naming the sides of a line array.
    corr : (B, N) array, optional
        Peak correlations (for ``min_corr``).
    array_velocity : (B, 2) array, optional
        The array's velocity (m/s, east/north); given, the delays are corrected for the
        array's motion (eqs. (M2), (M4) of :mod:`arrayproc.track.batch.motion`).

    Returns
    -------
    dict
        Per written row (from the first usable row on): ``time``, ``row`` (index into the
        input rows), ``x``, ``y`` (absolute, m), ``vx``, ``vy`` (m/s; 0 for the static model),
        ``cov`` (n, 4, 4) (static: velocity block 0), ``rel`` (n, 2) the position relative to
        the reference hydrophone, ``P`` (n, d, d) the state covariance, ``own`` (n, 4),
        ``side_weight`` (n,) the starboard hypothesis's weight (NaN without mirrors),
        ``updated`` (n,) bool (False: coasted), ``n_delays`` (n,) the delays used,
        ``side`` the sides searched and ``n_hypotheses``.

    Raises
    ------
    FormatError
        No row has two usable delays.
    ConfigError
        A filter that is not Gaussian.
    """
    d = {**DELAYS_DEFAULTS, **d}
    if filter_name not in GAUSSIAN_FILTERS:
        raise ConfigError(f"delays tracker: filter must be one of {', '.join(GAUSSIAN_FILTERS)}"
                          f", not {filter_name!r}")
    filt = make_filter(filter_name, **(filter_params or {}))
    t = np.asarray(times, float).reshape(-1)
    y = np.asarray(tau, float)
    el = np.asarray(elements, float)
    B, N = y.shape
    if el.shape != (B, N, 3):
        raise FormatError(f"delays: elements {el.shape} must be ({B}, {N}, 3)")
    if np.any(np.diff(t) < 0):
        raise FormatError("delays: row times must increase")
    sig, use, good = usable_delays(y, sigma, corr, ref, d)
    if array_velocity is not None:
        y = _static_array_delays(y, use, el, ref, sound_speed, heading_rad,
                                 np.asarray(array_velocity, float).reshape(B, 2))
    own = observer_states(t, el[:, ref, :2])
    k0 = int(np.flatnonzero(good)[0])
    hd0 = None if heading_rad is None else float(np.asarray(heading_rad, float)[k0])
    states, sides = initial_hypotheses(y[k0], sig[k0], el[k0] - el[k0, ref], ref, sound_speed,
                                       hd0, own[k0, 2:], d)
    bank = HypothesisBank(filt, motion_model(d), None, states, sides, prune_below=1e-9)
    from scipy.stats import chi2

    gate = chi2.ppf(d["gate_prob"], np.arange(N + 1)) if d["gate_prob"] > 0 else None
    n = B - k0
    dim = states[0].x.size
    X, P = np.empty((n, dim)), np.empty((n, dim, dim))
    sw = np.full(n, np.nan)
    upd = np.zeros(n, bool)
    nd = np.zeros(n, np.int64)
    for i, k in enumerate(range(k0, B)):
        ctx = Context(own[k], own[k if k == k0 else k - 1],
                      0.0 if heading_rad is None else float(heading_rad[k]), float(t[k]))
        bank.predict(0.0 if k == k0 else t[k] - t[k - 1], ctx)   # a coast unless updated
        if good[k]:
            model = _row_model(el[k], use[k], sig[k], ref, sound_speed, d)
            z = y[k, use[k]]
            if gate is None or bank.gate(z, model, ctx, gate[z.size]):
                bank.update([z] * len(states), ctx, model)
                upd[i], nd[i] = True, z.size
        bank.normalise("delays tracker")
        X[i], P[i] = bank.estimate_side()
        if bank.mirrored:
            sw[i] = bank.side_weight()
        bank.prune()
    rows = np.arange(k0, B)
    o = own[rows]
    cov = np.zeros((n, 4, 4))
    if dim == 4:
        vel = X[:, 2:] + o[:, 2:]
        cov[:] = P
    else:
        vel = np.zeros((n, 2))
        cov[:, :2, :2] = P
    return {"time": t[rows], "row": rows, "x": X[:, 0] + o[:, 0], "y": X[:, 1] + o[:, 1],
            "vx": vel[:, 0], "vy": vel[:, 1], "cov": cov, "rel": X[:, :2].copy(), "P": P,
            "own": o, "side_weight": sw, "updated": upd, "n_delays": nd,
            "side": np.array(list(dict.fromkeys(sides))), "n_hypotheses": len(states)}
