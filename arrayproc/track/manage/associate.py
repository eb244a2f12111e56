"""Measurement-to-track association: ellipsoidal gating, global nearest neighbour and JPDA.

Gating (Bar-Shalom, Willett & Tian, *Tracking and Data Fusion* (2011), sec. 2.3.2): a
measurement z is in the gate of a track when the squared Mahalanobis distance of its
innovation ν = z − ẑ with innovation covariance S,

    d² = νᵀ S⁻¹ ν ,                                                   (BWT eq. 2.3.2-2)

is below the χ² quantile of the gate probability P_G for dim(z) degrees of freedom.

GNN: the assignment maximising the joint likelihood of one-to-one pairs, i.e. minimising
Σ (d² + ln det 2πS) over gated pairs, solved by ``scipy.optimize.linear_sum_assignment``
(Blackman & Popoli 1999, sec. 6.5).

JPDA (Fortmann, Bar-Shalom & Scheffe 1983; BWT sec. 3.4): the marginal association
probabilities β_ij of every feasible joint event θ (each measurement to at most one track, each
track at most one measurement) with weights

    P(θ) ∝ Π_{(i,j)∈θ} P_D g_ij / λ · Π_{i unassigned} (1 − P_D P_G),   (BWT eq. 3.4.3-13)

g_ij = N(ν_ij; 0, S_ij) and λ the clutter density. Events are enumerated exactly within each
cluster of tracks sharing measurements (written here: scipy has no JPDA).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.optimize import linear_sum_assignment
from scipy.special import gammaincinv

from arrayproc.errors import ConfigError

#: Largest joint-event count enumerated exactly in one JPDA cluster.
MAX_EVENTS = 200_000


def gate_threshold(prob: float, dim: int) -> float:
    """χ² gate on d² for gate probability ``prob`` (0 < prob < 1) and ``dim`` measurement
    components.

    Parameters
    ----------
    prob : float
        Gate probability P_G.
    dim : int
        Measurement dimension.

    Returns
    -------
    float
        Threshold on the squared Mahalanobis distance (dimensionless).
    """
    if not 0.0 < prob < 1.0:
        raise ConfigError(f"gate probability must be in (0, 1), not {prob}")
    return float(2.0 * gammaincinv(0.5 * dim, prob))  # χ²_dim quantile


def mahalanobis(nu: np.ndarray, S: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Squared Mahalanobis distances and log-determinants of innovations.

    Parameters
    ----------
    nu : ndarray (n, m, k)
        Innovation of measurement j for track i, the measurement's units.
    S : ndarray (n, m, k, k) or (n, k, k)
        Innovation covariances (per pair, or per track when they do not depend on the
        measurement).

    Returns
    -------
    d2 : ndarray (n, m)
        νᵀ S⁻¹ ν.
    logdet : ndarray (n, m)
        ln det(2π S).
    """
    nu = np.asarray(nu, float)
    S = np.asarray(S, float)
    n, m, k = nu.shape
    if S.ndim == 3:
        S = np.broadcast_to(S[:, None], (n, m, k, k))
    if n == 0 or m == 0:
        return np.zeros((n, m)), np.zeros((n, m))
    L = np.linalg.cholesky(S)
    w = np.linalg.solve(L, nu[..., None])[..., 0]
    d2 = np.einsum("...i,...i->...", w, w)
    logdet = 2.0 * np.log(np.abs(np.diagonal(L, axis1=-2, axis2=-1))).sum(-1) \
        + k * math.log(2.0 * math.pi)
    return d2, logdet


def gnn(d2: np.ndarray, logdet: np.ndarray, gate: float) -> list[tuple[int, int]]:
    """Global-nearest-neighbour assignment of measurements to tracks.

    Parameters
    ----------
    d2, logdet : ndarray (n, m)
        From :func:`mahalanobis`.
    gate : float
        Threshold on d² (:func:`gate_threshold`).

    Returns
    -------
    list of (track, measurement)
        Assigned pairs, each inside the gate; a track or measurement appears at most once.
    """
    d2 = np.asarray(d2, float)
    if d2.size == 0:
        return []
    ok = d2 <= gate
    rows = np.flatnonzero(ok.any(1))
    cols = np.flatnonzero(ok.any(0))
    if rows.size == 0:
        return []
    cost = d2[np.ix_(rows, cols)] + logdet[np.ix_(rows, cols)]
    sub_ok = ok[np.ix_(rows, cols)]
    big = 1e6 + 2.0 * float(np.abs(cost[sub_ok]).max())
    cost = np.where(sub_ok, cost, big)
    r, c = linear_sum_assignment(cost)
    return [(int(rows[i]), int(cols[j])) for i, j in zip(r, c, strict=True) if sub_ok[i, j]]


def _clusters(ok: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """Connected components of the bipartite gating graph: (tracks, measurements) each."""
    n, m = ok.shape
    seen_t = np.zeros(n, bool)
    out = []
    for i0 in range(n):
        if seen_t[i0] or not ok[i0].any():
            continue
        ts, ms = {i0}, set()
        frontier = [i0]
        seen_t[i0] = True
        while frontier:
            i = frontier.pop()
            for j in np.flatnonzero(ok[i]):
                if j in ms:
                    continue
                ms.add(int(j))
                for i2 in np.flatnonzero(ok[:, j]):
                    if not seen_t[i2]:
                        seen_t[i2] = True
                        ts.add(int(i2))
                        frontier.append(int(i2))
        out.append((np.array(sorted(ts)), np.array(sorted(ms))))
    return out


def _walk(a: int, opts: list[np.ndarray], lsub: np.ndarray, lmiss: float, used: set[int],
          lw: float, choice: list[int], logs: list[float], picks: list[tuple[int, ...]]
          ) -> None:
    """Depth-first enumeration of joint events from track ``a`` on."""
    if a == len(opts):
        logs.append(lw)
        picks.append(tuple(choice))
        return
    choice.append(0)
    _walk(a + 1, opts, lsub, lmiss, used, lw + lmiss, choice, logs, picks)
    for j in opts[a]:
        j = int(j)
        if j not in used:
            used.add(j)
            choice[-1] = j + 1
            _walk(a + 1, opts, lsub, lmiss, used, lw + lsub[a, j], choice, logs, picks)
            used.discard(j)
    choice.pop()


def _events(opts: list[np.ndarray], lsub: np.ndarray, lmiss: float
            ) -> tuple[np.ndarray, np.ndarray]:
    """Every feasible joint event of one cluster: log-weights (E,) and choices (E, n_tracks)
    (0: no measurement, j + 1: measurement j)."""
    logs: list[float] = []
    picks: list[tuple[int, ...]] = []
    _walk(0, opts, lsub, lmiss, set(), 0.0, [], logs, picks)
    return np.array(logs), np.array(picks, np.int64).reshape(len(picks), len(opts))


def jpda(d2: np.ndarray, logdet: np.ndarray, gate: float, pd: float, pg: float,
         clutter_density: float) -> np.ndarray:
    """JPDA marginal association probabilities by exact joint-event enumeration.

    Parameters
    ----------
    d2, logdet : ndarray (n, m)
        From :func:`mahalanobis`.
    gate : float
        Threshold on d².
    pd, pg : float
        Detection and gate probabilities.
    clutter_density : float
        False measurements per unit measurement volume (the measurement's units).

    Returns
    -------
    ndarray (n, m + 1)
        β: column 0 the probability that track i had no measurement, column j + 1 that
        measurement j is track i's. Rows sum to 1.
    """
    d2 = np.asarray(d2, float)
    n, m = d2.shape
    beta = np.zeros((n, m + 1))
    beta[:, 0] = 1.0
    if n == 0 or m == 0:
        return beta
    if not (0 < pd <= 1 and 0 < pg <= 1 and clutter_density > 0):
        raise ConfigError("jpda: pd and pg must be in (0, 1], clutter density > 0")
    ok = d2 <= gate
    # log of P_D g_ij / λ for gated pairs; log(1 − P_D P_G) for a missed track
    lg = math.log(pd) - 0.5 * (d2 + logdet) - math.log(clutter_density)
    lmiss = math.log(max(1.0 - pd * pg, 1e-300))
    for ts, ms in _clusters(ok):
        sub = ok[np.ix_(ts, ms)]
        lsub = lg[np.ix_(ts, ms)]
        opts = [np.flatnonzero(sub[a]) for a in range(ts.size)]
        n_ev = math.prod(o.size + 1 for o in opts)
        if n_ev > MAX_EVENTS:
            raise ConfigError(f"jpda: a cluster of {ts.size} tracks and {ms.size} measurements "
                              f"has more than {MAX_EVENTS} joint events; use gnn or a smaller "
                              "gate")
        acc = np.zeros((ts.size, ms.size + 1))
        lw, P = _events(opts, lsub, lmiss)
        w = np.exp(lw - lw.max())
        w /= w.sum()
        for a in range(ts.size):
            np.add.at(acc[a], P[:, a], w)
        beta[ts, 0] = acc[:, 0]
        beta[np.ix_(ts, ms + 1)] = acc[:, 1:]
    return beta


__all__ = ["gate_threshold", "mahalanobis", "gnn", "jpda", "MAX_EVENTS", "GNN", "JPDA",
           "Association", "make_associator", "stacked_innovation", "stacked_update"]


# ----------------------------------------------------------------------- associator parts

def stacked_innovation(filt: Any, X: np.ndarray, P: np.ndarray, Z: np.ndarray, ctx: Any,
                       W: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """``filt.innovation`` of stacked tracks, with the tracks' hypothesis log-weights ``W``
    when the filter is a bank of hypotheses."""
    return filt.innovation(X, P, Z, ctx) if W is None else filt.innovation(X, P, Z, ctx, W)


def stacked_update(filt: Any, X: np.ndarray, P: np.ndarray, Z: np.ndarray, ctx: Any,
                   idx: np.ndarray, W: np.ndarray | None
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """``filt.update`` of the pairs (tracks, ``Z[idx]``): X, P and the new log-weights."""
    if W is None:
        Xu, Pu, _ = filt.update(X, P, Z, ctx, idx)
        return Xu, Pu, None
    Xu, Pu, _, Wu = filt.update(X, P, Z, ctx, idx, W)
    return Xu, Pu, Wu


@dataclass
class Association:
    """One scan's association and update: states X, P (and log-weights W) of the live
    tracks after the update, which tracks had a measurement (``hit``) and which (``meas``,
    −1 none), and which measurements fell inside a gate (``in_gate``) or were used
    (``used``)."""

    X: np.ndarray
    P: np.ndarray
    W: np.ndarray | None
    hit: np.ndarray
    meas: np.ndarray
    in_gate: np.ndarray
    used: np.ndarray


class _Gated:
    gate_prob: float

    def _gate(self, k: int) -> float:
        cache = self.__dict__.setdefault("_cache", {})
        if k not in cache:
            cache[k] = gate_threshold(self.gate_prob, k)
        return cache[k]

    def _score(self, filt: Any, X: np.ndarray, P: np.ndarray, Z: np.ndarray, ctx: Any,
               W: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, float]:
        nu, S = stacked_innovation(filt, X, P, Z, ctx, W)
        d2, logdet = mahalanobis(nu, S)
        return d2, logdet, self._gate(Z.shape[1])


@dataclass
class GNN(_Gated):
    """Global nearest neighbour inside the χ² gate of probability ``gate_prob``
    (:func:`gnn`), then the filter's update of the assigned pairs."""

    gate_prob: float = 0.999

    def __call__(self, filt: Any, X: np.ndarray, P: np.ndarray, Z: np.ndarray, ctx: Any,
                 W: np.ndarray | None = None) -> Association:
        n, m = X.shape[0], Z.shape[0]
        hit, meas, used = np.zeros(n, bool), np.full(n, -1, np.int64), np.zeros(m, bool)
        d2, logdet, gate = self._score(filt, X, P, Z, ctx, W)
        in_gate = (d2 <= gate).any(0)
        pairs = gnn(d2, logdet, gate)
        if pairs:
            ii = np.array([p[0] for p in pairs])
            jj = np.array([p[1] for p in pairs])
            Xu, Pu, Wu = stacked_update(filt, X[ii], P[ii], Z, ctx, jj,
                                        None if W is None else W[ii])
            X[ii], P[ii] = Xu, Pu
            if W is not None:
                W[ii] = Wu
            hit[ii] = True
            meas[ii] = jj
            used[jj] = True
        return Association(X, P, W, hit, meas, in_gate, used)


@dataclass
class JPDA(_Gated):
    """Joint probabilistic data association (:func:`jpda`): each track updated with the
    moment-matched mixture of its per-measurement updates and its prediction (for a linear
    model the PDA update, BWT eqs. 3.4.3-3 to 3.4.3-7); hypothesis log-weights are mixed
    with the same β. ``pd`` the detection probability, ``clutter_density`` λ."""

    gate_prob: float = 0.999
    pd: float = 0.9
    clutter_density: float = 1e-3

    def __call__(self, filt: Any, X: np.ndarray, P: np.ndarray, Z: np.ndarray, ctx: Any,
                 W: np.ndarray | None = None) -> Association:
        d2, logdet, gate = self._score(filt, X, P, Z, ctx, W)
        in_gate = (d2 <= gate).any(0)
        beta = jpda(d2, logdet, gate, self.pd, self.gate_prob, self.clutter_density)
        ii, jj = np.nonzero(beta[:, 1:] > 0)
        hit = (1.0 - beta[:, 0]) >= 0.5
        meas = np.where(hit, np.argmax(beta[:, 1:], axis=1), -1)
        used = np.zeros(Z.shape[0], bool)
        used[meas[meas >= 0]] = True
        if ii.size == 0:
            return Association(X, P, W, hit, meas, in_gate, used)
        Xu, Pu, Wu = stacked_update(filt, X[ii], P[ii], Z, ctx, jj,
                                    None if W is None else W[ii])
        b = beta[ii, jj + 1]
        Xn = X * beta[:, :1]
        np.add.at(Xn, ii, Xu * b[:, None])
        Pn = np.zeros_like(P)
        d0 = X - Xn
        Pn += beta[:, 0, None, None] * (P + d0[:, :, None] * d0[:, None, :])
        du = Xu - Xn[ii]
        np.add.at(Pn, ii, b[:, None, None] * (Pu + du[:, :, None] * du[:, None, :]))
        if W is not None:
            Wn = W * beta[:, :1]
            np.add.at(Wn, ii, Wu * b[:, None])
            W = Wn
        return Association(Xn, 0.5 * (Pn + Pn.transpose(0, 2, 1)), W, hit, meas, in_gate, used)


def make_associator(name: str, gate_prob: float = 0.999, pd: float = 0.9,
                    clutter_density: float = 1e-3) -> GNN | JPDA:
    """The associator part named ``"gnn"`` or ``"jpda"``."""
    if name == "gnn":
        return GNN(gate_prob)
    if name == "jpda":
        return JPDA(gate_prob, pd, clutter_density)
    raise ConfigError(f"tracker.association must be 'gnn' or 'jpda', not {name!r}")
