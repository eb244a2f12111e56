"""``measurements = "delays"``: recursive position tracking from hydrophone delays, thesis
section 3.2.2.2 (eqs. (3.37)-(3.40)).

Every row of a ``delays`` product (the ``tde`` stage: each hydrophone's delay to the reference
hydrophone in one snapshot) updates one source's position through the TDOA measurement model
(:class:`~arrayproc.track.models.tdoa.TDOA`, eqs. (3.38)-(3.39)) with any of the Gaussian filters
(EKF, UKF, CKF, GHF; :mod:`arrayproc.track.filters`). The element positions of each row are the
world positions of that snapshot's pose (the recording's ``/nav`` and array geometry,
:meth:`arrayproc.io.recording.Recording.poses`), so a towed array's motion between snapshots is
what synthesises the aperture the thesis speaks of.

State: the package's relative state (L-R paper eq. (1)), the source minus the observer, the
observer being the reference hydrophone. Motion (eq. (3.40)):

- ``motion = "static"`` (the thesis's choice, Φ = I on the absolute position): state [x, y];
  the relative position moves by the observer's displacement, x_k = x_{k−1} − (o_k − o_{k−1}),
  with an optional position random walk of intensity ``q`` (m²/s);
- ``motion = "cv"``: nearly constant velocity, state [x, y, ẋ, ẏ] (L-R paper eqs. (2)-(4),
  :class:`~arrayproc.track.models.motion.ConstantVelocity`), ``q`` the acceleration noise
  intensity (m²/s³).

Measurement noise: the delays of one row are all measured against one reference channel, so
their covariance is :func:`arrayproc.geo.tdoa.reference_covariance` of the row's σ (the
product's ``sigma`` column, or ``sigma_delay_s`` when set or when the product has none).
With ``array_motion`` (the default, as in ``arrayproc tma``) each row's delays are first
brought back to those of a static array, τ (1 + V·u/c) (:mod:`arrayproc.track.batch.motion`,
eqs. (M2), (M4); V the array's velocity from the navigation, u the row's plane-wave
direction): the wavefront crosses a moving array in a slightly different time, which moves
a line array's cone angle by about (v/c) cos θ cot θ (0.034° at 60° for 3 m/s) and, on the
20 m array of the validation, biased the static estimate by 4.5 m at 2 km (40 CRLB σ).
Missing delays (NaN), delays with ``corr < min_corr`` and rows with fewer than two usable
delays are left out (the track coasts through such a row).

Initialisation (from the first usable row): the plane-wave direction that fits the row's
delays best (least squares, :func:`arrayproc.track.batch.td_tma.plane_wave_directions`) and a
range prior ``range_m ± sigma_range_m`` along it (Ristic, Arulampalam & Gordon 2003, ch. 6:
the polar prior linearised into x, y), or with ``range_bank = [r_min, r_max, n]`` a bank of
n such priors at ranges spaced geometrically from r_min to r_max, each σ_r = r (ρ − 1)/2 with
ρ the ratio of neighbouring ranges (the range-parameterised filter bank, Peach 1995; Ristic
et al. 2003, ch. 6), run as hypotheses weighted by their likelihoods. One wide Gaussian prior
lets an EKF's first update, linearised far from a near source, throw the state across the
array (measured: 405 km off for a 2 km source with 6 ± 4 km). The bearing σ is the larger of
``sigma_bearing_deg`` and the fit's own σ (c σ_τ / ‖projected apertures‖ / sin θ). CV:
velocity 0 ± ``sigma_speed_mps`` per axis. A line array's delays give a cone angle, the same
for two mirror bearings (heading ∓ θ); ``side = "auto"`` runs both as hypotheses weighted by
their likelihoods (L-R paper eqs. (9)-(11)), ``port`` / ``starboard`` keeps one. The written
track is the mixture (eqs. (12)-(13)) of the hypotheses on the heavier side only
(``side_weight`` is the summed weight of the starboard hypotheses): a mixture over both sides
would put its mean between the mirrors, on the array's axis, until an ownship turn tells
them apart. Hypotheses whose
weight falls below 1e-9 are dropped. Optional gating (``gate_prob`` > 0): a row whose
normalised innovation exceeds the χ² quantile for every hypothesis is skipped.

Config (``arrayproc track DELAYS.h5 -c TRACKER.toml``)::

    [tracker]
    mode = "multi"
    measurements = "delays"
    filter = "ukf"            # ekf | ukf | ckf | ghf
    nav = "rec.h5"            # optional: recording with /nav and the array (default: source)
    [tracker.params]          # filter parameters (alpha/beta/kappa, gh_order)
    [tracker.delays]
    motion = "static"         # static (thesis eq. 3.40, Φ = I) | cv
    q = 0.0                   # static: m²/s; cv: m²/s³
    range_m = 5000.0          # initial range prior
    sigma_range_m = 3000.0
    range_bank = [1000.0, 20000.0, 6]  # optional: n priors from r_min to r_max (replaces
                              # range_m, sigma_range_m)
    sigma_bearing_deg = 0.5   # lower bound of the initial bearing σ
    sigma_speed_mps = 3.0     # cv: initial velocity σ per axis
    side = "auto"             # auto | port | starboard (line arrays)
    sigma_delay_s = 0.0       # > 0: this σ for every delay; 0: the product's sigma column
    min_corr = 0.0            # leave out delays with a lower peak correlation
    source_dz_m = 0.0         # source depth below the reference hydrophone, m
    gate_prob = 0.0           # > 0: χ² gate on the innovations
    group = ""                # delays group (default: the only one)
    array_motion = true       # correct the delays for the array's motion (below)
"""

from __future__ import annotations

import math
import os
import sys
from pathlib import Path
from typing import Any

import numpy as np

from arrayproc.config import read_toml, resolve_beside
from arrayproc.errors import ConfigError, FormatError
from arrayproc.geo.tdoa import reference_covariance
from arrayproc.io.text import as_text
from arrayproc.track.base import Param
from arrayproc.track.filters import FilterDivergence, make_filter
from arrayproc.track.manage import _kernels as kl
from arrayproc.track.models.base import MotionModel
from arrayproc.track.models.motion import ConstantVelocity
from arrayproc.track.models.tdoa import TDOA
from arrayproc.track.state import Context, GaussianState

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = ["StaticPosition", "RowTDOA", "DELAYS_DEFAULTS", "GAUSSIAN_FILTERS",
           "is_delays_config", "load_delays_config", "initial_hypotheses", "track_delays",
           "run_delays"]

#: filters the delays tracker accepts (the SRF is bearings-only, the RPF not Gaussian)
GAUSSIAN_FILTERS = ("ekf", "ukf", "ckf", "ghf")

DELAYS_DEFAULTS: dict[str, Any] = {
    "motion": "static", "q": 0.0, "range_m": 5000.0, "sigma_range_m": 3000.0,
    "sigma_bearing_deg": 0.5, "sigma_speed_mps": 3.0, "side": "auto", "sigma_delay_s": 0.0,
    "min_corr": 0.0, "source_dz_m": 0.0, "gate_prob": 0.0, "group": "", "range_bank": None,
    "array_motion": True,
}
_PRUNE = math.log(1e-9)
_TOP_KEYS = {"mode", "measurements", "filter", "nav", "params", "delays"}


class StaticPosition(MotionModel):
    """A static source in relative coordinates, thesis eq. (3.40) with Φ = I on the absolute
    position: x_k = x_{k−1} + o_{k−1} − o_k (o the observer position), plus a position random
    walk of intensity ``q`` (m²/s): Q = q Δt I."""

    name = "static"
    ndim = 2
    linear = True
    params = {"q": Param("float", 0.0, "position random-walk intensity, m²/s",
                         check=lambda v: None if v >= 0 else "must be >= 0")}

    def function_points(self, X: np.ndarray, dt: float, ctx: Context,
                        out: np.ndarray) -> None:
        """Relative positions after the observer's displacement (rows of ``X``)."""
        out[:] = X + (ctx.own_prev[:2] - ctx.own[:2])[None, :]

    def jacobian(self, x: np.ndarray, dt: float, ctx: Context | None = None) -> np.ndarray:
        """Φ = I (eq. (3.40))."""
        return np.eye(2)

    def covariance(self, dt: float) -> np.ndarray:
        """q Δt I."""
        return self.q * abs(float(dt)) * np.eye(2)


class RowTDOA(TDOA):
    """:class:`~arrayproc.track.models.tdoa.TDOA` with a σ per delay (``sigma_row``, the
    non-reference delays in element order), the noise covariance of delays measured against
    one reference channel (:func:`arrayproc.geo.tdoa.reference_covariance`)."""

    name = "tdoa_row"
    params = {"sigma_row": Param("any", None, "σ of each non-reference delay, s")}

    def _setup(self) -> None:
        super()._setup()
        if self.sigma_row is not None:
            s = np.asarray(self.sigma_row, float).reshape(-1)
            if s.size != self._keep.size or not np.all(np.isfinite(s) & (s > 0)):
                raise ConfigError(f"{self.name}.sigma_row: need {self._keep.size} positive "
                                  "finite values")
            self._R = reference_covariance(s)


# ----------------------------------------------------------------------------- config

def _read_doc(path: str) -> dict[str, Any] | None:
    try:
        with open(path, "rb") as fh:
            doc = tomllib.load(fh)
    except (OSError, tomllib.TOMLDecodeError, UnicodeDecodeError):
        return None
    t = doc.get("tracker")
    return t if isinstance(t, dict) else None


def is_delays_config(path: str) -> bool:
    """True when a tracker TOML reads ``mode = "multi"`` and ``measurements = "delays"``
    (errors are left to the full validation)."""
    t = _read_doc(path)
    return t is not None and t.get("mode") == "multi" and t.get("measurements") == "delays"


def _number(path: str, key: str, v: Any, positive: bool = False) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) \
            or v < 0 or (positive and v == 0):
        raise ConfigError(f"{path}: tracker.delays.{key} must be a number "
                          f"{'>' if positive else '>='} 0")
    return float(v)


def load_delays_config(path: str) -> dict[str, Any]:
    """Read and check a delays tracker TOML (module docstring); ConfigError naming the file
    and key.

    Parameters
    ----------
    path : str
        Tracker TOML.

    Returns
    -------
    dict
        ``filter``, ``params`` (the filter's), ``nav`` (or None), ``mode`` = "multi",
        ``multi`` = {"measurements": "delays"} and ``delays`` (every key of
        :data:`DELAYS_DEFAULTS`, checked).
    """
    doc, _ = read_toml(path, "tracker")
    t = doc.get("tracker")
    if not isinstance(t, dict):
        raise ConfigError(f"{path}: missing [tracker] table")
    for k in t:
        if k not in _TOP_KEYS:
            raise ConfigError(f"{path}: unknown key tracker.{k} (a delays tracker takes "
                              f"{', '.join(sorted(_TOP_KEYS))})")
    filt = t.get("filter", "ukf")
    if filt not in GAUSSIAN_FILTERS:
        raise ConfigError(f"{path}: tracker.filter must be one of {', '.join(GAUSSIAN_FILTERS)} "
                          f"for delays, not {filt!r}")
    params = t.get("params", {})
    if not isinstance(params, dict):
        raise ConfigError(f"{path}: tracker.params must be a table")
    nav = t.get("nav")
    if nav is not None and not isinstance(nav, str):
        raise ConfigError(f"{path}: tracker.nav must be a string")
    given = t.get("delays", {})
    if not isinstance(given, dict):
        raise ConfigError(f"{path}: tracker.delays must be a table")
    d = dict(DELAYS_DEFAULTS)
    for k, v in given.items():
        if k not in DELAYS_DEFAULTS:
            raise ConfigError(f"{path}: unknown key tracker.delays.{k}")
        if k in ("motion", "side", "group"):
            choices = {"motion": ("static", "cv"), "side": ("auto", "port", "starboard")}
            if not isinstance(v, str) or (k in choices and v not in choices[k]):
                raise ConfigError(f"{path}: tracker.delays.{k} must be "
                                  f"{' | '.join(choices.get(k, ('a group name',)))}, not {v!r}")
            d[k] = v
        elif k == "array_motion":
            if not isinstance(v, bool):
                raise ConfigError(f"{path}: tracker.delays.array_motion must be true or false")
            d[k] = v
        elif k == "range_bank":
            if (not isinstance(v, list) or len(v) != 3
                    or not all(isinstance(a, (int, float)) and not isinstance(a, bool)
                               and math.isfinite(a) for a in v)
                    or not 0 < v[0] < v[1] or not isinstance(v[2], int) or v[2] < 2):
                raise ConfigError(f"{path}: tracker.delays.range_bank must be [r_min, r_max, n]"
                                  " with 0 < r_min < r_max (m) and an integer n >= 2")
            d[k] = [float(v[0]), float(v[1]), int(v[2])]
        elif k == "source_dz_m":
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ConfigError(f"{path}: tracker.delays.source_dz_m must be a number")
            d[k] = float(v)
        else:
            d[k] = _number(path, k, v, positive=k in ("range_m", "sigma_range_m",
                                                      "sigma_bearing_deg", "sigma_speed_mps"))
    if d["gate_prob"] >= 1:
        raise ConfigError(f"{path}: tracker.delays.gate_prob must be < 1 (0: no gate)")
    if d["min_corr"] > 1:
        raise ConfigError(f"{path}: tracker.delays.min_corr must be <= 1")
    try:
        make_filter(filt, **params)
    except ConfigError as e:
        raise ConfigError(f"{path}: tracker.params: {e}") from None
    return {"filter": filt, "params": dict(params), "nav": nav, "mode": "multi",
            "multi": {"measurements": "delays"}, "delays": d}


# ----------------------------------------------------------------------------- tracker

def _motion(d: dict[str, Any]) -> MotionModel:
    if d["motion"] == "static":
        return StaticPosition(q=float(d["q"]))
    return ConstantVelocity(q1=float(d["q"]))


def initial_hypotheses(tau: np.ndarray, sigma: np.ndarray, elements: np.ndarray, ref: int,
                       sound_speed: float, heading_rad: float | None, own_vel: np.ndarray,
                       d: dict[str, Any]) -> tuple[list[GaussianState], list[str]]:
    """Initial states from one row of delays: plane-wave direction + range prior.

    Parameters
    ----------
    tau : (N,) array
        Delays to the reference (s), NaN where missing.
    sigma : (N,) array
        Their σ (s).
    elements : (N, 3) array
        Element positions relative to the reference element (m), world axes.
    ref : int
        Reference element.
    sound_speed : float
        m/s.
    heading_rad : float or None
        Forward direction of a line array (rad; None: from the last element to the reference).
    own_vel : (2,) array
        Observer velocity (m/s), for the CV relative velocity.
    d : dict
        The ``delays`` settings (:data:`DELAYS_DEFAULTS`).

    Returns
    -------
    states : list of GaussianState
        One per hypothesis: per side (two mirrors for a line array with ``side = "auto"``)
        one per range of the bank (or the one range prior).
    sides : list of str
        ``"port"``, ``"starboard"`` or ``""`` (2-D array), per hypothesis.
    """
    from arrayproc.track.batch.td_tma import plane_wave_directions

    el = np.asarray(elements, float)
    ok = np.isfinite(tau) & np.isfinite(sigma) & (sigma > 0)
    ok[ref] = False
    pw = plane_wave_directions(np.where(ok, tau, np.nan)[None], el[None, :, :2], ref,
                               sound_speed,
                               None if heading_rad is None else np.array([heading_rad]))
    dd = el[ok, :2] - el[ref, :2]
    s_mean = float(np.sqrt(np.mean(np.asarray(sigma, float)[ok] ** 2)))
    if "bearing" in pw:
        beta = [float(pw["bearing"][0])]
        sides = [""]
        s_fit = sound_speed * s_mean / max(float(np.sqrt(np.linalg.eigvalsh(dd.T @ dd)[0])),
                                           1e-9)
    else:
        th, h = float(pw["cone"][0]), float(pw["heading"][0])
        a = np.array([math.sin(h), math.cos(h)])
        s_fit = sound_speed * s_mean / max(float(np.linalg.norm(dd @ a)), 1e-9) \
            / max(math.sin(th), 0.05)
        cand = {"port": h - th, "starboard": h + th}
        sides = ["port", "starboard"] if d["side"] == "auto" else [d["side"]]
        beta = [cand[s] for s in sides]
    if not all(math.isfinite(b) for b in beta):
        raise FormatError("delays: the first usable row gives no plane-wave direction")
    s_b = max(math.radians(d["sigma_bearing_deg"]), s_fit)
    if d.get("range_bank"):
        r0, r1, nb = d["range_bank"]
        rho = (r1 / r0) ** (1.0 / (nb - 1))
        ranges = r0 * rho ** np.arange(nb)
        sig_r = ranges * (rho - 1.0) / 2.0
    else:
        ranges, sig_r = np.array([float(d["range_m"])]), np.array([float(d["sigma_range_m"])])
    cv = d["motion"] == "cv"
    out, names = [], []
    for b, side in zip(beta, sides, strict=True):
        u = np.array([math.sin(b), math.cos(b)])
        v = np.array([math.cos(b), -math.sin(b)])
        for r, sr in zip(ranges, sig_r, strict=True):
            Pxy = sr * sr * np.outer(u, u) + (r * s_b) ** 2 * np.outer(v, v)
            if cv:
                x = np.r_[r * u, -np.asarray(own_vel, float)[:2]]
                P = np.zeros((4, 4))
                P[:2, :2] = Pxy
                P[2:, 2:] = d["sigma_speed_mps"] ** 2 * np.eye(2)
            else:
                x, P = r * u, Pxy
            out.append(GaussianState(x, P))
            names.append(side)
    return out, names


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


def _estimate(states: list[GaussianState], logw: np.ndarray, alive: np.ndarray,
               stbd: np.ndarray, mirrored: bool) -> tuple[np.ndarray, np.ndarray]:
    """The written estimate: the mixture (L-R paper eqs. (12)-(13)) of the live hypotheses on
    the heavier side; the two sides are not mixed (their mean would lie on the array's axis)."""
    on = alive.copy()
    if mirrored:
        w_s = float(np.exp(logw[alive & stbd]).sum())
        on &= stbd if w_s >= 0.5 else ~stbd
    lw = np.where(on, logw, -np.inf)
    lw = lw - lw.max()
    lw -= math.log(np.exp(lw).sum())
    X = np.ascontiguousarray([st.x for st in states])
    P = np.ascontiguousarray([st.P for st in states])
    x = np.empty(X.shape[1])
    Pc = np.empty((X.shape[1], X.shape[1]))
    kl.lr_combine(X, P, lw, on, x, Pc, np.empty(X.shape[0]))
    return x, Pc


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
    if array_velocity is not None:
        y = _static_array_delays(y, use, el, ref, sound_speed, heading_rad,
                                 np.asarray(array_velocity, float).reshape(B, 2))
    own = observer_states(t, el[:, ref, :2])
    k0 = int(np.flatnonzero(good)[0])
    hd0 = None if heading_rad is None else float(np.asarray(heading_rad, float)[k0])
    states, sides = initial_hypotheses(y[k0], sig[k0], el[k0] - el[k0, ref], ref, sound_speed,
                                       hd0, own[k0, 2:], d)
    motion = _motion(d)
    nh = len(states)
    logw = np.full(nh, -math.log(nh))
    alive = np.ones(nh, np.bool_)
    from scipy.stats import chi2

    gate = chi2.ppf(d["gate_prob"], np.arange(N + 1)) if d["gate_prob"] > 0 else None
    n = B - k0
    dim = states[0].x.size
    X = np.empty((n, dim))
    P = np.empty((n, dim, dim))
    sw = np.full(n, np.nan)
    upd = np.zeros(n, bool)
    nd = np.zeros(n, np.int64)
    stbd = np.array([sd == "starboard" for sd in sides])
    mirrored = len(set(sides)) > 1
    for i, k in enumerate(range(k0, B)):
        dt = 0.0 if k == k0 else t[k] - t[k - 1]
        ctx = Context(own[k], own[k if k == k0 else k - 1],
                      0.0 if heading_rad is None else float(heading_rad[k]), float(t[k]))
        preds = []
        for h in range(nh):
            if not alive[h]:
                preds.append(states[h])
                continue
            try:
                preds.append(filt.predict(states[h], motion, dt, ctx))
            except FilterDivergence:
                alive[h] = False
                logw[h] = -np.inf
                preds.append(states[h])
        if good[k]:
            keep = use[k].copy()
            keep[ref] = True
            idx = np.flatnonzero(keep)
            model = RowTDOA(elements=el[k, idx] - el[k, ref], reference=int(np.searchsorted(
                idx, ref)), sound_speed=sound_speed, sigma_s=float(sig[k, use[k]].min()),
                sigma_row=sig[k, use[k]], source_dz_m=float(d["source_dz_m"]))
            z = y[k, use[k]]
            ok_gate = True
            if gate is not None:
                d2 = []
                for h in np.flatnonzero(alive):
                    nu, S = filt.innovation(preds[h], z, model, ctx)
                    d2.append(float(nu @ np.linalg.solve(S, nu)))
                ok_gate = min(d2) <= gate[z.size]
            if ok_gate:
                for h in np.flatnonzero(alive):
                    try:
                        states[h], ll = filt.update(preds[h], z, model, ctx)
                        logw[h] += ll
                    except FilterDivergence:
                        alive[h] = False
                        logw[h] = -np.inf
                upd[i] = True
                nd[i] = z.size
            else:
                states = preds
        else:
            states = preds
        if not kl.lr_normalise(logw, alive):
            raise FilterDivergence("delays tracker: every hypothesis diverged")
        X[i], P[i] = _estimate(states, logw, alive, stbd, mirrored)
        if mirrored:
            sw[i] = float(np.exp(logw[alive & stbd]).sum())
        if nh > 1:
            drop = alive & (logw < _PRUNE)
            if drop.any():
                alive &= ~drop
                logw[drop] = -np.inf
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
            "side": np.array(list(dict.fromkeys(sides))), "n_hypotheses": nh}


# ----------------------------------------------------------------------------- runner

def read_delays(products_path: str, group: str = "") -> dict[str, Any]:
    """The ``delays`` rows of a products file: ``time`` (B,), ``tau``, ``sigma``, ``corr``
    (B, N) or None, ``reference``, ``group`` and the root ``source``; sorted by time.

    Parameters
    ----------
    products_path : str
        Products file.
    group : str
        Group name ("" : the only group of kind ``delays``).

    Returns
    -------
    dict
    """
    from arrayproc.io.products import delays_columns, read_products

    if not os.path.exists(products_path):
        raise FormatError(f"{products_path}: no such file")
    prod = read_products(products_path)
    names = [n for n, g in prod.items() if n != "/" and as_text(g.get("kind")) == "delays"]
    if group:
        if group not in names:
            raise FormatError(f"{products_path}: no delays group {group!r}")
        name = group
    elif not names:
        raise FormatError(f"{products_path}: no delays group")
    elif len(names) > 1:
        raise ConfigError(f"{products_path}: several delays groups ({', '.join(names)}); "
                          "choose one with tracker.delays.group")
    else:
        name = names[0]
    d = delays_columns(prod[name], products_path)
    d.update(group=name, source=as_text(prod["/"].get("source", "")))
    return d


def run_delays(products_path: str, config_path: str, out_path: str,
               progress: bool = False) -> dict[str, np.ndarray]:
    """``arrayproc track DELAYS.h5 -c TRACKER.toml -o TRACKS.h5`` with
    ``measurements = "delays"``: one track (id 1) from every row, written as a ``tracks``
    group (status confirmed; ``row`` the products row).

    Parameters
    ----------
    products_path : str
        Products file with a ``delays`` group.
    config_path : str
        Tracker TOML (module docstring).
    out_path : str
        Tracks file to write (atomically).
    progress : bool
        One summary line on stderr.

    Returns
    -------
    dict
        :func:`track_delays`'s result.
    """
    from arrayproc.io.products import ProductsWriter
    from arrayproc.io.recording import Recording
    from arrayproc.track.manage.tracks import STATUS_CODES, Status

    cfg = load_delays_config(config_path)
    d = cfg["delays"]
    meas = read_delays(products_path, d["group"])
    src = cfg["nav"] or meas["source"]
    if not src:
        raise FormatError(f"{products_path}: no root attribute 'source' naming the recording; "
                          "set tracker.nav")
    rec_path = resolve_beside(src, config_path if cfg["nav"] else products_path)
    if not os.path.exists(rec_path):
        raise FormatError(f"{rec_path}: recording with the navigation not found (set "
                          "tracker.nav)")
    t = meas["time"]
    with Recording(rec_path) as rec:
        poses = rec.poses(t)
        c = float(rec.sound_speed)
        if d["array_motion"]:
            from arrayproc.track.batch.motion import nav_velocity
            vel = nav_velocity(rec.nav, t)
        else:
            vel = None
    el = np.stack([p.elements for p in poses]) if len(poses) else np.zeros((0, 0, 3))
    if el.shape[:2] != meas["tau"].shape:
        raise FormatError(f"{products_path}: delays have {meas['tau'].shape[1]} channels but "
                          f"the recording {rec_path} has {el.shape[1]} active channels")
    res = track_delays(t, meas["tau"], meas["sigma"], el, meas["reference"], c, d,
                       cfg["filter"], cfg["params"],
                       heading_rad=np.deg2rad([p.heading for p in poses]), corr=meas["corr"],
                       array_velocity=vel)
    if progress:
        r = float(np.hypot(*res["rel"][-1]))
        print(f"delays tracker ({cfg['filter']}, {d['motion']}): {res['time'].size} rows, "
              f"{int(res['updated'].sum())} updates, final range {r:.1f} m", file=sys.stderr)
    n = res["time"].size
    cfg_text = Path(config_path).read_text(encoding="utf-8", errors="replace")
    with ProductsWriter(out_path, source=str(products_path), chain=cfg_text,
                        attrs={"recording": str(rec_path)}) as w:
        g = w.group("tracks", "tracks", stage="track", mode="multi", measurements="delays",
                    filter=cfg["filter"], motion=d["motion"], lr=len(res["side"]) > 1,
                    array_motion=bool(d["array_motion"]),
                    sides=",".join(res["side"]))
        g.append(time=res["time"], track_id=np.ones(n, np.int64), x=res["x"], y=res["y"],
                 vx=res["vx"], vy=res["vy"], cov=res["cov"],
                 status=np.full(n, STATUS_CODES[Status.CONFIRMED.value], np.int8),
                 side_weight=res["side_weight"], own_x=res["own"][:, 0],
                 own_y=res["own"][:, 1],
                 row=np.where(res["updated"], meas["order"][res["row"]], -1).astype(np.int64))
    return res
