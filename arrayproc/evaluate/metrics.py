"""Multi-target metrics against simulator truth: OSPA, GOSPA, track purity, false tracks,
track breaks, and how long each source is held by one track.

OSPA (Schuhmacher, Vo & Vo, IEEE TSP 56(8), 2008, eq. (3)): for finite sets X (m points) and
Y (n points), m ≤ n, cut-off c > 0 and order p ≥ 1,

    d_p^(c)(X, Y) = ( (1/n) ( min_π Σ_i d^(c)(x_i, y_π(i))^p + c^p (n − m) ) )^(1/p),

d^(c)(x, y) = min(c, ‖x − y‖); 0 when both sets are empty.

GOSPA (Rahmathullah, García-Fernández & Svensson, FUSION 2017, eq. (1), with α ∈ (0, 2]):

    d_p^(c,α)(X, Y) = ( min_π Σ_i d^(c)(x_i, y_π(i))^p + (c^p / α) (n − m) )^(1/p);

for α = 2 (their Proposition 1) it equals the minimum over assignments γ of
(Σ_(i,j)∈γ ‖x_i − y_j‖^p + (c^p/2)(#missed + #false))^(1/p), which splits into localisation,
missed-target and false-target terms. Both optimal assignments come from
``scipy.optimize.linear_sum_assignment``.

Track-level measures follow Ristic, Vo & Clark (2011) and the CLEAR-MOT style bookkeeping:
at every time the confirmed tracks are assigned to the true sources (GNN on the distance,
gate ``gate``); a track's *purity* is the fraction of its rows assigned to its most frequent
source; a *false track* is a confirmed track whose rows are mostly unassigned; a *break* is a
change of the track holding a source; a source's *held fraction* is the share of the times it
is detected during which its principal track (the one holding it most often) holds it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from arrayproc.config import resolve_beside
from arrayproc.errors import ConfigError
from arrayproc.io.text import as_text


def _check(c: float, p: float) -> None:
    if not (c > 0 and np.isfinite(c)):
        raise ConfigError(f"metrics: cut-off c must be a positive number, not {c}")
    if not (p >= 1 and np.isfinite(p)):
        raise ConfigError(f"metrics: order p must be >= 1, not {p}")


def _dist(X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    X = np.asarray(X, float).reshape(len(X), -1)
    Y = np.asarray(Y, float).reshape(len(Y), -1)
    return np.linalg.norm(X[:, None, :] - Y[None, :, :], axis=-1)


def ospa(X: np.ndarray, Y: np.ndarray, c: float, p: float = 1.0) -> float:
    """OSPA distance (Schuhmacher et al. 2008, eq. (3)).

    Parameters
    ----------
    X, Y : ndarray (m, d), (n, d)
        Point sets (same units as ``c``).
    c : float
        Cut-off (units of the points).
    p : float
        Order, >= 1.

    Returns
    -------
    float
        Distance in [0, c].
    """
    _check(c, p)
    m, n = len(X), len(Y)
    if m == 0 and n == 0:
        return 0.0
    if m == 0 or n == 0:
        return float(c)
    D = np.minimum(_dist(X, Y), c) ** p
    r, k = linear_sum_assignment(D)
    big = max(m, n)
    return float(((D[r, k].sum() + c ** p * abs(m - n)) / big) ** (1.0 / p))


@dataclass(frozen=True)
class Gospa:
    """GOSPA distance and, for α = 2, its parts (each the p-th power contribution, so that
    ``distance**p == localisation + missed + false``); counts of missed and false points."""

    distance: float
    localisation: float
    missed: float
    false: float
    n_missed: int
    n_false: int


def gospa(X: np.ndarray, Y: np.ndarray, c: float, p: float = 2.0, alpha: float = 2.0
          ) -> Gospa:
    """GOSPA of estimates ``Y`` against truth ``X`` (Rahmathullah et al. 2017, eq. (1)).

    Parameters
    ----------
    X : ndarray (m, d)
        True points.
    Y : ndarray (n, d)
        Estimated points.
    c : float
        Cut-off (units of the points).
    p : float
        Order, >= 1.
    alpha : float
        In (0, 2]; the decomposition is that of α = 2.

    Returns
    -------
    Gospa
    """
    _check(c, p)
    if not 0 < alpha <= 2:
        raise ConfigError(f"metrics: GOSPA alpha must be in (0, 2], not {alpha}")
    m, n = len(X), len(Y)
    if m == 0 or n == 0:
        pen = c ** p / alpha * (m + n)
        return Gospa(float(pen ** (1 / p)), 0.0, c ** p / alpha * m, c ** p / alpha * n,
                     m, n)
    D = np.minimum(_dist(X, Y), c) ** p
    r, k = linear_sum_assignment(D)
    total = D[r, k].sum() + c ** p / alpha * abs(m - n)
    assigned = D[r, k] < c ** p  # pairs at the cut-off count as one missed + one false (α=2)
    loc = float(D[r, k][assigned].sum())
    n_ass = int(assigned.sum())
    nm, nf = m - n_ass, n - n_ass
    return Gospa(float(total ** (1 / p)), loc, c ** p / 2 * nm, c ** p / 2 * nf, nm, nf)


def over_time(truth: np.ndarray, estimates: list[np.ndarray], c: float, p: float = 2.0,
              alpha: float = 2.0) -> dict[str, np.ndarray]:
    """OSPA and GOSPA at every time.

    Parameters
    ----------
    truth : ndarray (S, T, d)
        True states of S sources at T times; NaN rows are absent sources.
    estimates : list of T ndarrays (n_t, d)
        Estimated points at each time.
    c, p, alpha : float
        Cut-off, order, GOSPA α.

    Returns
    -------
    dict
        ``ospa``, ``gospa``, ``gospa_localisation``, ``gospa_missed``, ``gospa_false`` (T,).
    """
    T = truth.shape[1]
    if len(estimates) != T:
        raise ConfigError("metrics: one estimate set per truth time")
    out = {k: np.zeros(T) for k in ("ospa", "gospa", "gospa_localisation", "gospa_missed",
                                    "gospa_false")}
    for t in range(T):
        X = truth[:, t]
        X = X[np.all(np.isfinite(X), axis=1)]
        Y = np.asarray(estimates[t], float).reshape(-1, truth.shape[2])
        out["ospa"][t] = ospa(X, Y, c, p)
        g = gospa(X, Y, c, p, alpha)
        out["gospa"][t] = g.distance
        out["gospa_localisation"][t] = g.localisation
        out["gospa_missed"][t] = g.missed
        out["gospa_false"][t] = g.false
    return out


@dataclass(frozen=True)
class TrackScores:
    """Track-level scores. ``labels[track_id]`` (n_rows,) source index or −1 per row;
    per source: ``held`` fraction, principal track id (−1: none), ``breaks``, detected
    count; per track: ``purity``, ``false`` flag."""

    labels: dict[int, np.ndarray]
    held: np.ndarray
    principal: np.ndarray
    breaks: np.ndarray
    n_detected: np.ndarray
    purity: dict[int, float]
    false_tracks: list[int]


def track_scores(truth: np.ndarray, detected: np.ndarray, track_time_idx: dict[int, np.ndarray],
                 track_values: dict[int, np.ndarray], gate: float) -> TrackScores:
    """Assign confirmed tracks to sources at each time and score them.

    Parameters
    ----------
    truth : ndarray (S, T, d)
        True values (NaN: absent) in the space where tracks are compared (e.g. cone angle,
        deg, or position, m).
    detected : ndarray (S, T) bool
        Whether the source had a measurement at that time (the denominator of ``held``).
    track_time_idx : dict of track id -> ndarray (n,) int
        Time index of each confirmed row of the track.
    track_values : dict of track id -> ndarray (n, d)
        The track's value at those rows (same space as truth).
    gate : float
        Largest distance for a track to hold a source.

    Returns
    -------
    TrackScores
    """
    S, T, _ = truth.shape
    holder = np.full((S, T), -1, np.int64)
    labels = {tid: np.full(len(ix), -1, np.int64) for tid, ix in track_time_idx.items()}
    by_time: dict[int, list[tuple[int, int]]] = {}
    for tid, ix in track_time_idx.items():
        for r, ti in enumerate(ix):
            by_time.setdefault(int(ti), []).append((tid, r))
    for ti, items in by_time.items():
        X = truth[:, ti]
        ok = np.flatnonzero(np.all(np.isfinite(X), axis=1))
        if ok.size == 0:
            continue
        Y = np.array([track_values[tid][r] for tid, r in items]).reshape(len(items), -1)
        D = _dist(X[ok], Y)
        a, b = linear_sum_assignment(np.where(D <= gate, D, 1e12))
        for i, j in zip(a, b, strict=True):
            if D[i, j] <= gate:
                tid, r = items[j]
                labels[tid][r] = ok[i]
                holder[ok[i], ti] = tid
    held = np.zeros(S)
    principal = np.full(S, -1, np.int64)
    breaks = np.zeros(S, np.int64)
    n_det = detected.sum(1)
    for s in range(S):
        h = holder[s][detected[s]]
        hh = h[h >= 0]
        if hh.size:
            ids, cnt = np.unique(hh, return_counts=True)
            principal[s] = ids[np.argmax(cnt)]
            held[s] = cnt.max() / max(1, n_det[s])
            seq = holder[s][holder[s] >= 0]
            breaks[s] = int(np.count_nonzero(np.diff(seq) != 0))
    purity = {}
    false_tracks = []
    for tid, lab in labels.items():
        if lab.size == 0:
            continue
        good = lab[lab >= 0]
        purity[tid] = float(np.bincount(good).max() / lab.size) if good.size else 0.0
        if good.size < 0.5 * lab.size:
            false_tracks.append(tid)
    return TrackScores(labels, held, principal, breaks, n_det, purity, false_tracks)


def evaluate_tracks_file(tracks_path: str, c: float = 1000.0, p: float = 2.0,
                         alpha: float = 2.0, cone_gate_deg: float = 5.0,
                         detect_gate_deg: float = 3.0, towship: bool = True) -> dict:
    """Score a multi-target ``tracks`` file against the truth of its simulated recording.

    The recording is the tracks file's root attr ``recording``; the products file (attr
    ``source``) gives the measurement times and, for bearings, which sources were detected
    (a row within ``detect_gate_deg`` of the true cone angle, and nearer to it than to any
    other source's). Bearing tracks are matched to
    sources in cone-angle space (gate ``cone_gate_deg``), other tracks in position space
    (gate ``c``); GOSPA/OSPA use positions (m) of the confirmed tracks at each scan.

    Parameters
    ----------
    tracks_path : str
        Output of ``arrayproc track`` in multi mode.
    c, p, alpha : float
        GOSPA/OSPA cut-off (m), order and α.
    cone_gate_deg, detect_gate_deg : float
        Gates (deg) for holding and for detection.
    towship : bool
        Count the tow ship (a real noise source in the data) as a source.

    Returns
    -------
    dict
        ``times`` (T,) s, ``sources`` names, ``ospa``/``gospa``/parts (T,), ``held``,
        ``breaks``, ``principal``, ``n_detected``, ``final_error_m`` per source,
        ``purity`` per track, ``false_tracks``, ``n_confirmed``.
    """
    from arrayproc.errors import FormatError
    from arrayproc.io import truth as truth_mod
    from arrayproc.io.products import read_products
    from arrayproc.io.recording import Recording

    prod = read_products(tracks_path)
    groups = list(prod.groups("tracks").values())
    if not groups:
        raise FormatError(f"{tracks_path}: no tracks group")
    g = groups[0]
    root = prod["/"]
    rec_path = resolve_beside(as_text(root.get("recording", "")), tracks_path)
    try:
        rec = Recording(rec_path, require_geometry=False)
    except Exception as e:  # noqa: BLE001 - any open failure is the same user error
        raise FormatError(f"{tracks_path}: recording {rec_path!r} with the truth cannot be "
                          f"opened ({e})") from None
    with rec:
        srcs = truth_mod.sources(rec, towship=towship)
        if not srcs:
            raise FormatError(f"{rec_path}: no /truth/sources to score against")
        names = sorted(srcs)
        meas = read_products(resolve_beside(as_text(root.get("source", "")), tracks_path))
        mb = list(meas.groups("bearings").values())
        mgroups = {"bearings": mb[-1]} if mb else {}  # the last bearings group
        bearing = "cone_deg" in g
        if bearing and "bearings" in mgroups:
            mt = np.asarray(mgroups["bearings"]["time"], float)
        else:
            mt = np.asarray(g["time"], float)
        times = np.unique(mt)
        T = times.size
        pos = np.stack([np.stack([np.interp(times, srcs[s]["time"], srcs[s]["position"][:, i])
                                  for i in range(2)], -1) for s in names])
        detected = np.ones((len(names), T), bool)
        if bearing:
            cones = truth_mod.cone_angles(rec, times)
            cone_truth = np.stack([cones[s] for s in names])[..., None]
            mc = np.asarray(mgroups["bearings"]["cone_deg"], float) \
                if "bearings" in mgroups else np.asarray(g["cone_deg"], float)
            ti = np.searchsorted(times, mt)
            # a row detects the source whose true cone angle is nearest, within the gate
            dc = np.abs(mc[None, :] - cone_truth[:, ti, 0])
            near_src = np.argmin(dc, axis=0)
            for si in range(len(names)):
                near = (near_src == si) & (dc[si] <= detect_gate_deg)
                detected[si] = np.bincount(ti[near], minlength=T) > 0
    tid = np.asarray(g["track_id"], np.int64)
    from arrayproc.track.manage.tracks import status_names
    st = status_names(g["status"]) if "status" in g else np.full(tid.size, "confirmed")
    conf = st == "confirmed"
    tt = np.asarray(g["time"], float)
    ti_rows = np.searchsorted(times, tt)
    ti_rows = np.clip(ti_rows, 0, T - 1)
    on_scan = np.isclose(times[ti_rows], tt)
    keep = conf & on_scan
    xy = np.stack([np.asarray(g["x"], float), np.asarray(g["y"], float)], 1)
    vals = np.asarray(g["cone_deg"], float)[:, None] if bearing else xy
    ids = np.unique(tid[keep])
    tix = {int(i): ti_rows[keep & (tid == i)] for i in ids}
    tv = {int(i): vals[keep & (tid == i)] for i in ids}
    scores = track_scores(cone_truth if bearing else pos, detected, tix, tv,
                          cone_gate_deg if bearing else c)
    est = [xy[keep & (ti_rows == k)] for k in range(T)]
    # truth present only while the source is detected (a passive sensor cannot see others)
    tp = pos.copy()
    tp[~detected] = np.nan
    curves = over_time(tp, est, c, p, alpha)
    final = np.full(len(names), np.nan)
    for si in range(len(names)):
        pr = int(scores.principal[si])
        if pr < 0:
            continue
        rows = np.flatnonzero(keep & (tid == pr))
        lab = scores.labels[pr]
        mine = rows[lab == si]
        if mine.size:
            r = mine[-1]
            final[si] = float(np.linalg.norm(xy[r] - pos[si, ti_rows[r]]))
    return {"times": times, "sources": names, **curves, "held": scores.held,
            "breaks": scores.breaks, "principal": scores.principal,
            "n_detected": scores.n_detected, "final_error_m": final,
            "purity": scores.purity, "false_tracks": scores.false_tracks,
            "n_confirmed": int(ids.size), "c": c, "p": p, "alpha": alpha}


__all__ = ["ospa", "gospa", "Gospa", "over_time", "track_scores", "TrackScores",
           "evaluate_tracks_file"]
