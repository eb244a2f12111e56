"""Several sources' tracks from rows of delays: the TDOA tracker's banks under the track
manager's parts.

A ``delays`` product of a ``tde`` stage with ``peaks`` > 1 holds one row per source and
snapshot (several rows at one time). Rows of one time form a scan. Every track is one
:class:`~arrayproc.track.manage.bank.HypothesisBank` (the mirror sides and range priors of
:func:`~arrayproc.track.delays.initial.initial_hypotheses`, exactly as the one-source tracker
of :func:`~arrayproc.track.delays.tracker.track_delays`) carried by a
:class:`~arrayproc.track.manage.tracks.Track`; each scan

1. predicts every live track's bank to the scan time;
2. gates and assigns the scan's rows to the tracks by global nearest neighbour
   (:func:`~arrayproc.track.manage.associate.gnn` on d² = min over the bank's live
   hypotheses of νᵀ S⁻¹ ν plus ln det 2πS, the χ² gate of ``gate_prob`` for the row's number of
   delays; ``gate_prob`` = 0: no gate);
3. updates each assigned bank with its row (thesis eqs. (3.38)-(3.39), reweighting eqs.
   (9)-(11) of the L-R paper);
4. starts a tentative track from every row left over (in no track's gate), confirms by
   M-of-N (:class:`~arrayproc.track.manage.initiate.MofN`, ``confirm = [m, n]``) and deletes
   after ``max_misses`` scans without a row
   (:class:`~arrayproc.track.manage.delete.DeletionRule`; 0 = never).

With one row per scan and the defaults (no gate, ``confirm = [1, 1]``, ``max_misses`` = 0) the
one track is the one-source tracker's, row for row.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from arrayproc.errors import ConfigError, FormatError
from arrayproc.track.delays.config import DELAYS_DEFAULTS, GAUSSIAN_FILTERS
from arrayproc.track.delays.initial import initial_hypotheses, motion_model
from arrayproc.track.delays.tracker import _row_model, _static_array_delays, usable_delays
from arrayproc.track.filters import make_filter
from arrayproc.track.manage.associate import gate_threshold, gnn
from arrayproc.track.manage.bank import HypothesisBank
from arrayproc.track.manage.delete import DeletionRule
from arrayproc.track.manage.initiate import MofN
from arrayproc.track.manage.tracks import Status, Track
from arrayproc.track.state import Context

__all__ = ["track_delay_sources", "scans_of"]


def scans_of(times: np.ndarray) -> list[np.ndarray]:
    """Rows of each distinct time (the rows sorted by time), in time order."""
    t = np.asarray(times, float)
    if t.size == 0:
        return []
    cut = np.flatnonzero(np.diff(t) != 0) + 1
    return np.split(np.arange(t.size), cut)


def _d2(bank: HypothesisBank, z: np.ndarray, model: Any, ctx: Context) -> tuple[float, float]:
    """Smallest d² = νᵀ S⁻¹ ν over the bank's live hypotheses and that hypothesis's
    ln det 2πS."""
    best = (np.inf, 0.0)
    for h in np.flatnonzero(bank.alive):
        nu, S = bank.filter.innovation(bank.states[h], z, model, ctx)
        d2 = float(nu @ np.linalg.solve(S, nu))
        if d2 < best[0]:
            sign, ld = np.linalg.slogdet(2 * np.pi * S)
            best = (d2, float(ld))
    return best


def _start(k: int, y: np.ndarray, sig: np.ndarray, el: np.ndarray, ref: int, c: float,
           heading_rad: np.ndarray | None, own: np.ndarray, d: dict, filt: Any,
           t: float, next_id: int) -> Track:
    hd = None if heading_rad is None else float(heading_rad[k])
    states, sides = initial_hypotheses(y[k], sig[k], el[k] - el[k, ref], ref, c, hd, own[2:],
                                       d)
    bank = HypothesisBank(filt, motion_model(d), None, states, sides, prune_below=1e-9)
    tr = Track(next_id, states[0].x.copy(), states[0].P.copy(), t)
    tr.meta.update(bank=bank, rows=[], out=[])
    return tr


def track_delay_sources(times: np.ndarray, tau: np.ndarray, sigma: np.ndarray | None,
                        elements: np.ndarray, ref: int, sound_speed: float, d: dict[str, Any],
                        filter_name: str = "ukf", filter_params: dict[str, Any] | None = None,
                        heading_rad: np.ndarray | None = None, corr: np.ndarray | None = None,
                        array_velocity: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Tracks of several sources from rows of delays (module docstring).

    Parameters are those of :func:`~arrayproc.track.delays.tracker.track_delays` (rows sorted
    by time; several rows may share a time), with ``d`` also read for ``confirm``,
    ``max_misses`` and ``gate_prob``.

    Returns
    -------
    dict
        One entry per (scan, live track) from each track's birth: ``track_id`` (from 1),
        ``status`` (names), and the columns of ``track_delays`` (``time``, ``row``, ``x``,
        ``y``, ``vx``, ``vy``, ``cov``, ``rel``, ``P``, ``own``, ``side_weight``,
        ``updated``, ``n_delays``), plus ``side`` and ``n_hypotheses`` (of the first track).
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
    scans = scans_of(t)
    first = np.array([s[0] for s in scans])
    ts = t[first]
    own = np.zeros((len(scans), 4))
    own[:, :2] = el[first, ref, :2]
    if len(scans) > 1:
        own[:, 2:] = np.gradient(own[:, :2], ts, axis=0)
    confirm = MofN(*[int(v) for v in d["confirm"]])
    delete = DeletionRule(max_misses=int(d["max_misses"])) if d["max_misses"] > 0 else None
    gate = d["gate_prob"] if d["gate_prob"] > 0 else None
    tracks: list[Track] = []
    for i, rows in enumerate(scans):
        ctx_prev = own[i - 1] if i else own[i]
        live = [tr for tr in tracks if tr.alive]
        ctx = Context(own[i], ctx_prev, 0.0 if heading_rad is None
                      else float(heading_rad[rows[0]]), float(ts[i]))
        for tr in live:
            tr.meta["bank"].predict(float(ts[i] - tr.time), ctx)
            tr.time = float(ts[i])
        rows_g = [int(k) for k in rows if good[k]]
        models = {k: _row_model(el[k], use[k], sig[k], ref, sound_speed, d) for k in rows_g}
        zs = {k: y[k, use[k]] for k in rows_g}
        pairs: list[tuple[int, int]] = []
        if live and rows_g:
            if gate is None and len(live) == 1 and len(rows_g) == 1:
                pairs = [(0, 0)]
            else:
                D2 = np.full((len(live), len(rows_g)), np.inf)
                LD = np.zeros_like(D2)
                for a, tr in enumerate(live):
                    for b, k in enumerate(rows_g):
                        d2, ld = _d2(tr.meta["bank"], zs[k], models[k], ctx)
                        if gate is None or d2 <= gate_threshold(gate, zs[k].size):
                            D2[a, b], LD[a, b] = d2, ld
                ok = np.isfinite(D2)
                pairs = gnn(np.where(ok, D2, 1e300), np.where(ok, LD, 0.0), 1e299)
        taken = set()
        hit = np.zeros(len(live), bool)
        for a, b in pairs:
            k = rows_g[b]
            tr = live[a]
            bank = tr.meta["bank"]
            bank.update([zs[k]] * len(bank.states), ctx, models[k])
            hit[a] = True
            taken.add(k)
            tr.meta["out"].append((i, k, True, zs[k].size))
        for a, tr in enumerate(live):
            if not hit[a]:
                tr.meta["out"].append((i, int(rows[0]), False, 0))
            tr.hits.append(bool(hit[a]))
            tr.misses = 0 if hit[a] else tr.misses + 1
            if tr.status is Status.TENTATIVE:
                confirm.apply(tr)
            elif delete is not None and delete.should_delete(tr, float(ts[i]), 0.0):
                tr.status = Status.DELETED
        for k in rows_g:
            if k in taken:
                continue
            tr = _start(k, y, sig, el, ref, sound_speed, heading_rad, own[i], d, filt,
                        float(ts[i]), len(tracks) + 1)
            bank = tr.meta["bank"]
            birth = Context(own[i], own[i], ctx.heading, float(ts[i]))
            bank.predict(0.0, birth)
            bank.update([zs[k]] * len(bank.states), birth, models[k])
            tr.hits.append(True)
            confirm.apply(tr)
            tr.meta["out"].append((i, k, True, zs[k].size))
            tracks.append(tr)
        for tr in [tr for tr in tracks if tr.alive or tr.meta["out"][-1][0] == i]:
            if tr.meta["out"][-1][0] != i:
                continue
            bank = tr.meta["bank"]
            bank.normalise("delays tracker")
            x, P = bank.estimate_side()
            tr.x, tr.P = x, P
            sw = bank.side_weight() if bank.mirrored else np.nan
            bank.prune()
            tr.meta["rows"].append((i,) + tr.meta["out"][-1][1:] + (x, P, sw, tr.status.value))
    return _columns(tracks, ts, own)


def _columns(tracks: list[Track], ts: np.ndarray, own: np.ndarray) -> dict[str, Any]:
    """The rows of every track, in time order then track id."""
    recs = [(r[0], tr.id) + r[1:] for tr in tracks for r in tr.meta["rows"]]
    recs.sort(key=lambda r: (r[0], r[1]))
    n = len(recs)
    if n == 0:
        raise FormatError("delays: no row started a track")
    dim = recs[0][5].size
    X = np.array([r[5] for r in recs]).reshape(n, dim)
    P = np.array([r[6] for r in recs]).reshape(n, dim, dim)
    scan = np.array([r[0] for r in recs])
    o = own[scan]
    cov = np.zeros((n, 4, 4))
    if dim == 4:
        vel = X[:, 2:] + o[:, 2:]
        cov[:] = P
    else:
        vel = np.zeros((n, 2))
        cov[:, :2, :2] = P
    b0 = tracks[0].meta["bank"]
    return {"time": ts[scan], "row": np.array([r[2] for r in recs], np.int64),
            "track_id": np.array([r[1] for r in recs], np.int64),
            "status": np.array([r[8] for r in recs], dtype=object),
            "x": X[:, 0] + o[:, 0], "y": X[:, 1] + o[:, 1], "vx": vel[:, 0], "vy": vel[:, 1],
            "cov": cov, "rel": X[:, :2].copy(), "P": P, "own": o,
            "side_weight": np.array([r[7] for r in recs], float),
            "updated": np.array([r[3] for r in recs], bool),
            "n_delays": np.array([r[4] for r in recs], np.int64),
            "side": np.array(list(dict.fromkeys(b0.sides.tolist()))),
            "n_hypotheses": len(b0.states)}
