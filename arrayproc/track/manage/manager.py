"""The multi-target loop over scans: predict, gate, associate, update, initiate, confirm,
coast, delete (Blackman & Popoli 1999, ch. 3 and 6; Bar-Shalom, Willett & Tian 2011,
secs. 2.3 and 3.4).

Each scan (time t, measurements Z (m, k), context such as the ownship pose):

1. every live track is predicted to t (one batched call of the filter);
2. innovations ν_ij and covariances S_ij of every pair give d²_ij (:func:`mahalanobis`);
3. GNN assigns measurements one-to-one inside the gate, or JPDA weights them (β_ij);
4. assigned tracks are updated (JPDA: the moment-matched mixture of the per-measurement
   updates and the prediction, which for a linear-Gaussian model equals the PDA update
   BWT eqs. 3.4.3-3 to 3.4.3-7);
5. a measurement inside no live track's gate starts a tentative track (``initiator``);
6. M-of-N confirms or drops tentative tracks, the deletion rule coasts or deletes confirmed
   ones, duplicates are merged, and every live track records a history point.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Any

import numpy as np

from arrayproc.errors import ConfigError
from arrayproc.track.manage.associate import gate_threshold, gnn, jpda, mahalanobis
from arrayproc.track.manage.delete import DeletionRule
from arrayproc.track.filters.stacked import StackedFilter
from arrayproc.track.manage.initiate import MofN
from arrayproc.track.manage.tracks import Status, Track

Initiator = Callable[[np.ndarray, float, Any, int], "tuple[np.ndarray, np.ndarray] | None"]


class TrackManager:
    """Multi-target tracker over scans.

    Parameters
    ----------
    filt : StackedFilter
        Predict / innovation / update of stacked tracks
        (:class:`~arrayproc.track.filters.stacked.StackedEKF` with any motion and measurement
        model, or a hypothesis bank of them).
    initiator : callable
        ``initiator(Z, t, ctx, j) -> (x, P)`` or None: the state of a new tentative track from
        measurement j of the scan (None: do not start one).
    association : {"gnn", "jpda"}
        Assignment method.
    gate_prob : float
        Gate probability P_G (χ² gate on d²).
    confirm : MofN
        Confirmation rule.
    delete : DeletionRule
        Coasting and deletion rule.
    pd : float
        Detection probability (JPDA).
    clutter_density : float
        False measurements per unit measurement volume (JPDA).
    """

    def __init__(self, filt: StackedFilter, initiator: Initiator, association: str = "gnn",
                 gate_prob: float = 0.999, confirm: MofN | None = None,
                 delete: DeletionRule | None = None, pd: float = 0.9,
                 clutter_density: float = 1e-3) -> None:
        if association not in ("gnn", "jpda"):
            raise ConfigError(f"tracker.association must be 'gnn' or 'jpda', not "
                              f"{association!r}")
        self.filt = filt
        self.initiator = initiator
        self.association = association
        self.gate_prob = float(gate_prob)
        self.confirm = confirm or MofN()
        self.delete = delete or DeletionRule()
        self.pd = float(pd)
        self.clutter_density = float(clutter_density)
        self.tracks: list[Track] = []
        self._next_id = 0
        self._gate: dict[int, float] = {}
        self._last_hit: dict[int, float] = {}

    @property
    def live(self) -> list[Track]:
        """Tracks not deleted."""
        return [tr for tr in self.tracks if tr.alive]

    def _gate_for(self, k: int) -> float:
        if k not in self._gate:
            self._gate[k] = gate_threshold(self.gate_prob, k)
        return self._gate[k]

    def step(self, t: float, Z: np.ndarray, ctx: Any = None) -> None:
        """Process one scan: measurements ``Z`` (m, k) at time ``t`` (s), context ``ctx``
        passed to the filter and the initiator."""
        Z = np.asarray(Z, float)
        if Z.ndim == 1:
            Z = Z[:, None]
        m = Z.shape[0]
        live = self.live
        n = len(live)
        used = np.zeros(m, bool)
        in_gate = np.zeros(m, bool)
        hit = np.zeros(n, bool)
        meas = np.full(n, -1, np.int64)
        if n:
            X = np.array([tr.x for tr in live])
            P = np.array([tr.P for tr in live])
            dt = np.array([t - tr.time for tr in live])
            X, P = self.filt.predict(X, P, dt, ctx)
            if m:
                nu, S = self.filt.innovation(X, P, Z, ctx)
                d2, logdet = mahalanobis(nu, S)
                gate = self._gate_for(Z.shape[1])
                in_gate = (d2 <= gate).any(0)
                if self.association == "gnn":
                    pairs = gnn(d2, logdet, gate)
                    if pairs:
                        ii = np.array([p[0] for p in pairs])
                        jj = np.array([p[1] for p in pairs])
                        X[ii], P[ii], _ = self.filt.update(X[ii], P[ii], Z, ctx, jj)
                        hit[ii] = True
                        meas[ii] = jj
                        used[jj] = True
                else:
                    X, P, hit, meas = self._jpda_update(X, P, Z, ctx, d2, logdet, gate)
                    used[meas[meas >= 0]] = True
            for a, tr in enumerate(live):
                tr.x, tr.P, tr.time = X[a], P[a], float(t)
        # initiation from measurements in no live track's gate
        new: list[Track] = []
        for j in np.flatnonzero(~used & ~in_gate):
            init = self.initiator(Z, float(t), ctx, int(j))
            if init is None:
                continue
            tr = Track(self._next_id, np.asarray(init[0], float), np.asarray(init[1], float),
                       float(t))
            self._next_id += 1
            tr.hits.append(True)
            tr.record(int(j))
            self._last_hit[tr.id] = float(t)
            new.append(tr)
        for a, tr in enumerate(live):
            tr.hits.append(bool(hit[a]))
            if hit[a]:
                tr.misses = 0
                self._last_hit[tr.id] = float(t)
            else:
                tr.misses += 1
            if tr.status is Status.TENTATIVE:
                self.confirm.apply(tr)
            elif self.delete.should_delete(tr, float(t), self._last_hit[tr.id]):
                tr.status = Status.DELETED
        for tr in self.delete.duplicates(live):
            tr.status = Status.DELETED
        for a, tr in enumerate(live):
            tr.record(int(meas[a]))
        for tr in new:
            self.confirm.apply(tr)  # a 1-of-N rule confirms at birth
            tr.history[-1].status = tr.status
        self.tracks.extend(new)

    def _jpda_update(self, X: np.ndarray, P: np.ndarray, Z: np.ndarray, ctx: Any,
                     d2: np.ndarray, logdet: np.ndarray, gate: float
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        beta = jpda(d2, logdet, gate, self.pd, self.gate_prob, self.clutter_density)
        ii, jj = np.nonzero(beta[:, 1:] > 0)
        hit = (1.0 - beta[:, 0]) >= 0.5
        meas = np.where(hit, np.argmax(beta[:, 1:], axis=1), -1)
        if ii.size == 0:
            return X, P, hit, meas
        Xu, Pu, _ = self.filt.update(X[ii], P[ii], Z, ctx, jj)
        Xn = X * beta[:, :1]
        np.add.at(Xn, ii, Xu * beta[ii, jj + 1][:, None])
        Pn = np.zeros_like(P)
        d0 = X - Xn
        Pn += beta[:, 0, None, None] * (P + d0[:, :, None] * d0[:, None, :])
        du = Xu - Xn[ii]
        np.add.at(Pn, ii, beta[ii, jj + 1][:, None, None]
                  * (Pu + du[:, :, None] * du[:, None, :]))
        return Xn, 0.5 * (Pn + Pn.transpose(0, 2, 1)), hit, meas

    def run(self, scans: Iterable[tuple[float, np.ndarray, Any]]) -> list[Track]:
        """Process scans ``(t, Z, ctx)`` in time order; returns every track (all statuses)."""
        for t, Z, ctx in scans:
            self.step(t, Z, ctx)
        return self.tracks


__all__ = ["TrackManager"]
