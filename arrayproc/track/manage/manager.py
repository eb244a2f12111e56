"""The multi-target loop over scans, composed of parts: predict, associate + update,
initiate, confirm, coast, delete (Blackman & Popoli 1999, ch. 3 and 6; Bar-Shalom, Willett &
Tian 2011, secs. 2.3 and 3.4).

Each scan (time t, measurements Z (m, k), context such as the ownship pose):

1. every live track is predicted to t (one batched call of the stacked filter);
2. the **associator** (:class:`~arrayproc.track.manage.associate.GNN` or
   :class:`~arrayproc.track.manage.associate.JPDA`) gates every (track, measurement) pair on
   d²_ij, assigns or weights the measurements and updates the tracks;
3. a measurement inside no live track's gate starts a tentative track (the **initiator**);
4. the **confirmer** (M-of-N, :class:`~arrayproc.track.manage.initiate.MofN`) confirms or
   drops tentative tracks, the **deleter**
   (:class:`~arrayproc.track.manage.delete.DeletionRule`) coasts or deletes confirmed ones
   and merges duplicates, and every live track records a history point.

A track whose filter is a bank of hypotheses (:class:`~arrayproc.track.manage.bank.
StackedBank`) carries their log-weights; the manager hands them to the filter with the states.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import numpy as np

from arrayproc.track.filters.stacked import StackedFilter
from arrayproc.track.manage.associate import GNN, JPDA, make_associator
from arrayproc.track.manage.delete import DeletionRule
from arrayproc.track.manage.initiate import Initiator, MofN
from arrayproc.track.manage.tracks import Status, Track


class TrackManager:
    """Multi-target tracker over scans, composed of a stacked filter and four parts.

    Parameters
    ----------
    filt : StackedFilter
        Predict / innovation / update of stacked tracks
        (:class:`~arrayproc.track.filters.stacked.StackedEKF` with any motion and measurement
        model, or a :class:`~arrayproc.track.manage.bank.StackedBank` of them).
    initiator : callable
        ``initiator(Z, t, ctx, j) -> (x, P)`` (a bank's tracks: ``(x, P, logw)``) or None:
        the state of a new tentative track from measurement j of the scan.
    association : {"gnn", "jpda"} or associator
        The associator part, or its name (built with ``gate_prob``, ``pd`` and
        ``clutter_density``).
    gate_prob : float
        Gate probability P_G (χ² gate on d²).
    confirm : MofN
        Confirmer part.
    delete : DeletionRule
        Deleter part (coasting, deletion, duplicates).
    pd : float
        Detection probability (JPDA).
    clutter_density : float
        False measurements per unit measurement volume (JPDA).

    Examples
    --------
    Two targets seen as 2-D positions, tracked by an EKF (exactly the Kalman filter on a
    linear model) with GNN, 3-of-4 confirmation and deletion after 3 misses:

    >>> import numpy as np
    >>> from arrayproc.track.filters.stacked import StackedEKF
    >>> from arrayproc.track.manage.delete import DeletionRule
    >>> from arrayproc.track.manage.initiate import MofN
    >>> from arrayproc.track.models.motion import ConstantVelocity
    >>> from arrayproc.track.models.position import Position
    >>> filt = StackedEKF(ConstantVelocity(q1=0.05, axes=2), Position(axes=2, sigma=5.0))
    >>> init = lambda Z, t, ctx, j: (np.r_[Z[j], 0, 0], np.diag([25.0, 25, 100, 100]))
    >>> mgr = TrackManager(filt, init, "gnn", confirm=MofN(3, 4),
    ...                    delete=DeletionRule(max_misses=3))
    >>> for k in range(6):
    ...     mgr.step(float(k), np.array([[10.0 * k, 0.0], [0.0, 500.0 - 5 * k]]))
    >>> sorted(tr.status.value for tr in mgr.live)
    ['confirmed', 'confirmed']
    """

    def __init__(self, filt: StackedFilter, initiator: Initiator,
                 association: str | GNN | JPDA = "gnn", gate_prob: float = 0.999,
                 confirm: MofN | None = None, delete: DeletionRule | None = None,
                 pd: float = 0.9, clutter_density: float = 1e-3) -> None:
        self.filt = filt
        self.initiator = initiator
        self.associator = (make_associator(association, float(gate_prob), float(pd),
                                           float(clutter_density))
                           if isinstance(association, str) else association)
        self.confirm = confirm or MofN()
        self.delete = delete or DeletionRule()
        self.bank = getattr(filt, "n_hypotheses", 1) > 1
        self.tracks: list[Track] = []
        self._next_id = 0
        self._last_hit: dict[int, float] = {}

    @property
    def live(self) -> list[Track]:
        """Tracks not deleted."""
        return [tr for tr in self.tracks if tr.alive]

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
            W = np.array([tr.logw for tr in live]) if self.bank else None
            dt = np.array([t - tr.time for tr in live])
            X, P = self.filt.predict(X, P, dt, ctx)
            if m:
                a = self.associator(self.filt, X, P, Z, ctx, W)
                X, P, W = a.X, a.P, a.W
                hit, meas, in_gate, used = a.hit, a.meas, a.in_gate, a.used
            for i, tr in enumerate(live):
                tr.x, tr.P, tr.time = X[i], P[i], float(t)
                if W is not None:
                    tr.logw = W[i]
        new = self._initiate(Z, float(t), ctx, ~used & ~in_gate)
        self._confirm_delete(live, hit, meas, float(t))
        for tr in new:
            self.confirm.apply(tr)  # a 1-of-N rule confirms at birth
            tr.history[-1].status = tr.status
        self.tracks.extend(new)

    def _initiate(self, Z: np.ndarray, t: float, ctx: Any, free: np.ndarray) -> list[Track]:
        """Tentative tracks from the measurements ``free`` (in no live track's gate)."""
        new: list[Track] = []
        for j in np.flatnonzero(free):
            init = self.initiator(Z, t, ctx, int(j))
            if init is None:
                continue
            tr = Track(self._next_id, np.asarray(init[0], float), np.asarray(init[1], float), t)
            if len(init) > 2:
                tr.logw = np.asarray(init[2], float)
            self._next_id += 1
            tr.hits.append(True)
            tr.record(int(j))
            self._last_hit[tr.id] = t
            new.append(tr)
        return new

    def _confirm_delete(self, live: list[Track], hit: np.ndarray, meas: np.ndarray,
                        t: float) -> None:
        """Hits and misses, confirmation of tentative tracks, deletion of confirmed ones and
        of duplicates, then one history point per live track."""
        for i, tr in enumerate(live):
            tr.hits.append(bool(hit[i]))
            if hit[i]:
                tr.misses = 0
                self._last_hit[tr.id] = t
            else:
                tr.misses += 1
            if tr.status is Status.TENTATIVE:
                self.confirm.apply(tr)
            elif self.delete.should_delete(tr, t, self._last_hit[tr.id]):
                tr.status = Status.DELETED
        for tr in self.delete.duplicates(live):
            tr.status = Status.DELETED
        for i, tr in enumerate(live):
            tr.record(int(meas[i]))

    def run(self, scans: Iterable[tuple[float, np.ndarray, Any]]) -> list[Track]:
        """Process scans ``(t, Z, ctx)`` in time order; returns every track (all statuses)."""
        for t, Z, ctx in scans:
            self.step(t, Z, ctx)
        return self.tracks


__all__ = ["TrackManager", "Initiator"]
