"""Azimuths of two or more static compact arrays fused in one multi-target tracker
(``measurements = "fused_bearings"``).

Each products file holds one static array's ``bearings`` rows (a volumetric array's
``azimuth_deg``); its recording's ``/nav`` and ``/array`` place the array
(:func:`arrayproc.track.batch.cross_fix_run.array_position`, the phase centre). A track's state
is Cartesian, ``[x, y, ẋ, ẏ]`` (m, m/s, x east, y north, the recordings' local frame), moved by
the constant-velocity model (L-R paper eqs. (2)-(4); BLK 2001 eq. 6.2.2-12).

Scans: the rows of one array at one time, rows closer than ``merge_deg`` in azimuth merged
into their strongest (:func:`arrayproc.track.multi.bearings.bearing_scans`); the scans of all
arrays in time order (one array after the other at equal times). Each scan's context is its
array's position, ``ctx.own = [x_a, y_a, 0, 0]``; the measurement model is the bearing of
L-R paper eq. (7), γ = atan2(x − x_a, y − y_a), through
:class:`~arrayproc.track.models.frame.ObserverRelative`, so one EKF
(:class:`~arrayproc.track.filters.stacked.StackedEKF`) takes every array's rows, each relative
to its own array.

Association (GNN or JPDA), M-of-N confirmation and deletion are the manager's parts
(:func:`~arrayproc.track.multi.compose.compose_manager`). Initiation
(:class:`CrossFixInitiator`): a bearing in no track's gate is kept for ``pair_s`` seconds;
a free bearing of another array within that time starts a tentative track at the two rays'
intersection (:func:`cross_fix_point`), unless the rays cross at less than ``min_cross_deg``
(near-parallel: the fix is ill-conditioned) or meet behind an array or beyond
``max_range_m``. Two vessels seen by two arrays give ghost crossings (array A's ray to one
vessel with array B's to the other); a track started on one takes a true bearing of each
array and would leave the other vessel's bearings of one array without a free partner for
good. So a *persistent* free bearing (``persist`` free bearings of its array within
``merge_deg`` over the last ``4 pair_s``, which clutter rarely makes) may also pair with a
recent bearing of another array that a track took.
"""

from __future__ import annotations

import math
import os
from typing import Any

import numpy as np

from arrayproc.errors import ConfigError, FormatError
from arrayproc.geo.rays import ray_intersection
from arrayproc.io.text import as_text
from arrayproc.track.filters.stacked import StackedEKF
from arrayproc.track.manage.manager import TrackManager
from arrayproc.track.manage.tracks import Track
from arrayproc.track.models.bearing import Bearing
from arrayproc.track.models.frame import ObserverRelative
from arrayproc.track.models.motion import ConstantVelocity
from arrayproc.track.multi.bearings import bearing_scans
from arrayproc.track.multi.compose import compose_manager
from arrayproc.track.state import Context

__all__ = ["cross_fix_point", "CrossFixInitiator", "read_fused_array", "fused_scans",
           "fused_manager", "track_fused"]

#: arrays closer than this (m) are one position: no cross-fix between them
SAME_SITE_M = 1.0


def cross_fix_point(a: np.ndarray, ba: float, b: np.ndarray, bb: float, sigma: float,
                    min_cross_rad: float, max_range: float
                    ) -> tuple[np.ndarray, np.ndarray] | None:
    """Intersection of the rays from ``a`` at bearing ``ba`` and from ``b`` at ``bb`` (rad,
    clockwise from north) with its covariance.

    The covariance is J diag(σ², σ²) Jᵀ, J = ∂p/∂(βa, βb) the Jacobian of the intersection
    (central differences; analytically each column is r_k / sin γ along the other ray,
    γ the crossing angle).

    Parameters
    ----------
    a, b : ndarray (2,)
        Array positions, m.
    ba, bb : float
        Bearings, rad.
    sigma : float
        Bearing σ, rad.
    min_cross_rad : float
        Smallest crossing angle (rad); nearer-parallel rays give None.
    max_range : float
        Largest distance (m) of the fix from either array; farther gives None.

    Returns
    -------
    (p, C) or None
        The fix (2,) m and its covariance (2, 2) m², or None (parallel, behind an array, too
        far).
    """
    if abs(math.sin(ba - bb)) < math.sin(min_cross_rad):
        return None
    p = ray_intersection(a, ba, b, bb)
    if p is None or max(np.hypot(*(p - a)), np.hypot(*(p - b))) > max_range:
        return None
    h = 1e-6
    J = np.empty((2, 2))
    for k, (da, db) in enumerate(((h, 0.0), (0.0, h))):
        p1 = ray_intersection(a, ba + da, b, bb + db)
        p0 = ray_intersection(a, ba - da, b, bb - db)
        if p1 is None or p0 is None:
            return None
        J[:, k] = (p1 - p0) / (2 * h)
    return p, sigma * sigma * (J @ J.T)


class CrossFixInitiator:
    """The manager's initiator (module doc): ``init(Z, t, ctx, j)`` of a free bearing
    ``Z[j, 0]`` (rad) seen from ``ctx.own[:2]``; the state at ``t`` from the cross-fix with
    the latest kept free bearing of another array (its age Δt adds (σ_v Δt)² per axis),
    else, for a persistent bearing (module doc), with the latest bearing of another array a
    track took; or None (the bearing is kept). :meth:`observe` after each scan.

    Parameters
    ----------
    fcfg : dict
        The checked ``tracker.fused`` table.
    """

    def __init__(self, fcfg: dict[str, Any]) -> None:
        self.sigma = math.radians(float(fcfg["sigma_bearing_deg"]))
        self.sv = float(fcfg["sigma_speed_mps"])
        self.pair_s = float(fcfg["pair_s"])
        self.min_cross = math.radians(float(fcfg["min_cross_deg"]))
        self.max_range = float(fcfg["max_range_m"])
        self.persist = int(fcfg["persist"])
        self.persist_s = 4.0 * self.pair_s
        self.near = math.radians(float(fcfg["merge_deg"]))
        #: free bearings kept: (t, site (2,), bearing rad); every recent free bearing; the
        #: bearings that were in a track's gate (:meth:`observe`)
        self.kept: list[tuple[float, np.ndarray, float]] = []
        self.free: list[tuple[float, np.ndarray, float]] = []
        self.seen: list[tuple[float, np.ndarray, float]] = []
        self.asked: set[int] = set()

    def __call__(self, Z: np.ndarray, t: float, ctx: Context, j: int
                 ) -> tuple[np.ndarray, np.ndarray] | None:
        site = np.asarray(ctx.own, float)[:2]
        beta = float(Z[j, 0])
        self.asked.add(j)
        self.kept = [k for k in self.kept if t - k[0] <= self.pair_s]
        self.seen = [k for k in self.seen if t - k[0] <= self.pair_s]
        self.free = [k for k in self.free if t - k[0] <= self.persist_s]
        self.free.append((t, site, beta))
        pools = [(self.kept, True)]
        if self.persist and self._persistent(site, beta):
            pools.append((self.seen, False))
        for pool, consume in pools:
            for i in range(len(pool) - 1, -1, -1):  # the latest first
                tk, sk, bk = pool[i]
                if np.hypot(*(sk - site)) < SAME_SITE_M:
                    continue
                fix = cross_fix_point(site, beta, sk, bk, self.sigma, self.min_cross,
                                      self.max_range)
                if fix is None:
                    continue
                if consume:
                    del pool[i]
                p, C = fix
                P = np.zeros((4, 4))
                P[:2, :2] = C + (self.sv * (t - tk)) ** 2 * np.eye(2)
                P[2:, 2:] = self.sv * self.sv * np.eye(2)
                return np.r_[p, 0.0, 0.0], P
        self.kept.append((t, site, beta))
        return None

    def _persistent(self, site: np.ndarray, beta: float) -> bool:
        """``persist`` or more free bearings of this array within ``merge_deg`` of ``beta``
        over the last ``persist_s`` (this one included): a source no track explains."""
        n = sum(1 for _t, s, b in self.free if np.hypot(*(s - site)) < SAME_SITE_M
                and abs(math.remainder(b - beta, 2 * math.pi)) <= self.near)
        return n >= self.persist

    def observe(self, t: float, ctx: Context, Z: np.ndarray) -> None:
        """After the manager's step over the scan ``Z`` (rad): keep its bearings not offered
        to the initiator (those in a track's gate) as partners of later persistent free
        bearings of other arrays (a track started on a ghost crossing, which takes a true
        bearing of each array, must not block the true track for good)."""
        site = np.asarray(ctx.own, float)[:2]
        self.seen.extend((t, site, float(Z[j, 0])) for j in range(Z.shape[0])
                         if j not in self.asked)
        self.asked = set()


def read_fused_array(products_path: str, tma_cfg: dict[str, Any]) -> dict[str, Any]:
    """One array's azimuth rows and position.

    Parameters
    ----------
    products_path : str
        Products file of one static array (a ``bearings`` group, root attribute ``source``
        naming its recording).
    tma_cfg : dict
        The single-mode keys (``bearings``: the group's name, when several).

    Returns
    -------
    dict
        ``time`` (s), ``azimuth_deg``, ``score`` (dB, −inf unknown), ``xy`` (2,) m, ``products``
        and ``recording``.
    """
    from arrayproc.io.products import read_products
    from arrayproc.track.batch.cross_fix_run import array_position, named_recording
    from arrayproc.track.multi.run import _columns, _group

    if not os.path.exists(products_path):
        raise FormatError(f"{products_path}: no such file")
    prod = read_products(products_path)
    rec = named_recording(products_path, as_text(prod["/"].get("source", "")))
    g = _group(prod, "bearings", products_path, tma_cfg.get("bearings"))
    col = "azimuth_deg" if "azimuth_deg" in g else "bearing_stbd_deg"
    b = _columns(g, ("time", col), products_path)
    score = np.asarray(g.get("snr_db", g.get("level_db", np.zeros_like(b["time"]))), float)
    ok = np.isfinite(b["time"]) & np.isfinite(b[col])
    t = b["time"]
    xy = array_position(products_path, rec, np.unique(t[ok])) if ok.any() else None
    if xy is None:
        raise FormatError(f"{products_path}: no bearing rows")
    return {"time": t, "azimuth_deg": np.where(ok, b[col], np.nan),
            "score": np.where(np.isfinite(score), score, -np.inf), "ok": ok, "xy": xy,
            "products": products_path, "recording": rec}


def fused_scans(arrays: list[dict[str, Any]], merge_deg: float
                ) -> list[tuple[float, int, np.ndarray, np.ndarray]]:
    """Every array's scans (:func:`~arrayproc.track.multi.bearings.bearing_scans` on the
    azimuths), in time order across arrays: (t, array index, Z (m, 1) rad, rows (m,))."""
    out = []
    for k, a in enumerate(arrays):
        idx = np.flatnonzero(a["ok"])
        for t, Z, r in bearing_scans(a["time"][idx], a["azimuth_deg"][idx], a["score"][idx],
                                     merge_deg):
            out.append((t, k, np.deg2rad(Z), idx[r]))
    out.sort(key=lambda s: (s[0], s[1]))
    return out


def fused_manager(cfg: dict[str, Any]) -> TrackManager:
    """Track manager of ``fused_bearings`` (module doc): EKF of the CV state with the
    observer-relative bearing model, cross-fix initiation, the configured parts."""
    f = cfg["fused"]
    filt = StackedEKF(ConstantVelocity(q1=float(f["q"]), axes=2),
                      ObserverRelative(Bearing(sigma_deg=float(f["sigma_bearing_deg"]))))
    return compose_manager(cfg, filt, CrossFixInitiator(f), (0, 1), float(f["merge_d2"]))


def track_fused(arrays: list[dict[str, Any]], cfg: dict[str, Any]) -> list[Track]:
    """Run the fused tracker over the arrays' scans; ``meta['rows']`` and ``meta['array']``
    of every track hold, per history point, the products row and the array index of the
    measurement used (−1: coasted) and ``meta['azimuth_deg']`` its azimuth (NaN)."""
    sites = np.stack([a["xy"] for a in arrays])
    for i in range(len(arrays)):
        for j in range(i):
            if np.hypot(*(sites[i] - sites[j])) < SAME_SITE_M:
                raise ConfigError(f"{arrays[i]['products']} and {arrays[j]['products']}: the "
                                  "arrays are at the same position (within 1 m): no cross-fix")
    scans = fused_scans(arrays, float(cfg["fused"]["merge_deg"]))
    mgr = fused_manager(cfg)
    first: dict[int, int] = {}
    for s, (t, k, Z, _rows) in enumerate(scans):
        ctx = Context(np.r_[sites[k], 0.0, 0.0], t=t)
        mgr.step(t, Z, ctx)
        mgr.initiator.observe(t, ctx, Z)
        for tr in mgr.tracks[len(first):]:
            first[tr.id] = s
    for tr in mgr.tracks:
        h = tr.arrays()
        n = h["meas"].size
        rows, arr = np.full(n, -1, np.int64), np.full(n, -1, np.int64)
        az = np.full(n, np.nan)
        for p, j in enumerate(h["meas"]):
            if j >= 0:
                _t, k, Z, r = scans[first[tr.id] + p]
                rows[p], arr[p], az[p] = r[j], k, np.degrees(Z[j, 0]) % 360.0
        tr.meta.update(rows=rows, array=arr, azimuth_deg=az)
    return mgr.tracks
