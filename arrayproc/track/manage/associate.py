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


__all__ = ["gate_threshold", "mahalanobis", "gnn", "jpda", "MAX_EVENTS"]
