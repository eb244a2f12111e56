"""The hypothesis bank: parallel filters weighted by their likelihoods (L-R paper section III,
eqs. (9)-(13)), the one implementation every tracker uses.

A bank holds the hypotheses of a track — the two mirror sides of a line array's bearing pair
(eq. (8)), a bank of range priors (the range-parameterised filter, Peach 1995; Ristic,
Arulampalam & Gordon 2003, ch. 6), or both — and for each step:

1. predicts every live hypothesis (a step without a measurement is a coast);
2. optionally gates the measurement (χ² on the innovation of every live hypothesis);
3. updates hypothesis h with its measurement z_h (a mirror side its member of the pair) and
   reweights, ω_k^h ∝ p_k^h ω_{k−1}^h (eqs. (9)-(11), :func:`~arrayproc.track.manage._kernels.
   lr_normalise`);
4. prunes hypotheses whose weight fell below a threshold, or floors the weights (a mirror
   side that must be able to come back after a turn);
5. gives the combined estimate (eqs. (12)-(13), :func:`~arrayproc.track.manage._kernels.
   lr_combine`) or the estimate of the heavier side only.

:class:`HypothesisBank` runs one track with any filter of :mod:`arrayproc.track.filters`
(Gaussian or particle): the single-target tracker, the TMA of each multi-target track, the
TDOA tracker. :class:`StackedBank` runs the hypotheses of many stacked tracks through a
stacked filter (:mod:`arrayproc.track.filters.stacked`): the multi-target bearing tracker's
mirror sides. Both use the same weight kernels.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from arrayproc.track.filters.base import Filter, FilterDivergence
from arrayproc.track.filters.stacked import StackedEKF, innovation_stacked, update_stacked
from arrayproc.track.manage import _kernels as kl
from arrayproc.track.manage.associate import mahalanobis
from arrayproc.track.models.base import MeasurementModel, MotionModel
from arrayproc.track.state import Context

__all__ = ["HypothesisBank", "StackedBank", "normalise_floor"]


class HypothesisBank:
    """The hypotheses of one track, equal initial weights ω^h = 1/m (section III).

    Parameters
    ----------
    filt : Filter
        The filter every hypothesis runs.
    motion_model : MotionModel
    measurement_model : MeasurementModel
    states : sequence of states
        The initial state of each hypothesis.
    sides : sequence of str, optional
        Side of each hypothesis (``"port"``, ``"starboard"`` or ``""``) for
        :meth:`estimate_side` and :meth:`side_weight`.
    prune_below : float, optional
        Weight under which a hypothesis is dropped by :meth:`prune` (e.g. 1e-9).

    Examples
    --------
    Two mirror hypotheses of a bearing, stepped with their members of the pair:

    >>> import numpy as np
    >>> from arrayproc.track.filters import make_filter
    >>> from arrayproc.track.models.bearing import Bearing
    >>> from arrayproc.track.models.motion import ConstantVelocity
    >>> from arrayproc.track.state import Context
    >>> ukf = make_filter("ukf")
    >>> P0 = np.diag([1e6, 1e6, 4.0, 4.0])
    >>> bank = HypothesisBank(ukf, ConstantVelocity(q1=1e-4), Bearing(sigma_deg=1.0),
    ...                       [ukf.initialize([2000.0, 2000.0, 0, 0], P0),
    ...                        ukf.initialize([-2000.0, 2000.0, 0, 0], P0)])
    >>> ctx = Context(np.zeros(4))
    >>> status = bank.step(10.0, ctx, [np.pi / 4, -np.pi / 4])
    >>> x, P, w = bank.combine()
    >>> bool(np.isclose(w.sum(), 1.0))
    True
    """

    def __init__(self, filt: Filter, motion_model: MotionModel,
                 measurement_model: MeasurementModel, states: Sequence[Any],
                 sides: Sequence[str] | None = None, prune_below: float | None = None) -> None:
        self.filter = filt
        self.motion_model = motion_model
        self.measurement_model = measurement_model
        self.states = list(states)
        m = len(self.states)
        self.logw = np.full(m, -math.log(m))
        self.alive = np.ones(m, dtype=np.bool_)
        self.sides = np.array(list(sides) if sides is not None else [""] * m)
        self.prune_log = None if prune_below is None else math.log(prune_below)

    @classmethod
    def from_priors(cls, filt: Filter, motion_model: MotionModel,
                    measurement_model: MeasurementModel,
                    priors: Sequence[tuple[np.ndarray, np.ndarray]],
                    sides: Sequence[str] | None = None, t: float = 0.0,
                    prune_below: float | None = None) -> HypothesisBank:
        """A bank from prior means and covariances ``priors`` [(x0, P0), …] (e.g. one per
        side and range of a range-parameterised bank)."""
        return cls(filt, motion_model, measurement_model,
                   [filt.initialize(x, P, t=t) for x, P in priors], sides, prune_below)

    @property
    def mirrored(self) -> bool:
        """Hypotheses on both sides of a line array."""
        return len(set(self.sides.tolist()) - {""}) > 1

    def _kill(self, h: int) -> None:
        self.alive[h] = False
        self.logw[h] = -np.inf

    def predict(self, dt: float, ctx: Context) -> int:
        """Predict every live hypothesis over ``dt`` s (alone: a coast). Returns status bits
        (1 a covariance was repaired, 2 a hypothesis diverged and was dropped)."""
        status = 0
        for h, state in enumerate(self.states):
            if self.alive[h]:
                st, pred = self._guarded(h, self.filter.predict, state, self.motion_model, dt,
                                         ctx)
                status |= st
                if pred is not None:
                    self.states[h] = pred
        return status

    def _guarded(self, h: int, step: Any, *args: Any) -> tuple[int, Any]:
        """``step(*args)`` of hypothesis h: (status bits, result); a divergence drops h and
        gives (2, None), a repaired covariance sets bit 1."""
        rep = self.filter.n_repairs
        try:
            out = step(*args)
        except FilterDivergence:
            self._kill(h)
            return 2, None
        return (1 if self.filter.n_repairs > rep else 0), out

    def gate(self, z: Any, measurement_model: MeasurementModel, ctx: Context,
             threshold: float) -> bool:
        """True when ``z`` lies inside the χ² gate ``threshold`` (d² = νᵀ S⁻¹ ν) of at least
        one live hypothesis (Gaussian filters)."""
        d2 = []
        for h in np.flatnonzero(self.alive):
            nu, S = self.filter.innovation(self.states[h], z, measurement_model, ctx)
            d2.append(float(nu @ np.linalg.solve(S, nu)))
        return bool(d2) and min(d2) <= threshold

    def update(self, zs: Sequence[Any], ctx: Context,
               measurement_model: MeasurementModel | None = None) -> int:
        """Update hypothesis h with ``zs[h]`` and add its log-likelihood to its weight
        (eq. (9)); a diverged hypothesis is dropped. Status bits as :meth:`predict`."""
        meas = self.measurement_model if measurement_model is None else measurement_model
        status = 0
        for h in range(len(self.states)):
            if self.alive[h]:
                st, out = self._guarded(h, self.filter.update, self.states[h], zs[h], meas, ctx)
                status |= st
                if out is not None:
                    self.states[h] = out[0]
                    self.logw[h] += out[1]
        return status

    def normalise(self, who: str = "lr") -> None:
        """ω^h normalised (eqs. (10)-(11)); FilterDivergence when every hypothesis died."""
        if not kl.lr_normalise(self.logw, self.alive):
            raise FilterDivergence(f"{who}: every hypothesis diverged")

    def step(self, dt: float, ctx: Context, zs: Sequence[Any],
             measurement_model: MeasurementModel | None = None) -> int:
        """Predict every hypothesis, update hypothesis h with ``zs[h]`` and reweight:
        ω_k^h ∝ p_k^h ω_{k−1}^h (eqs. (9)-(11)). A diverged hypothesis gets weight zero.

        Parameters
        ----------
        dt : float
            Time step, s.
        ctx : Context
            Observer context of the step.
        zs : sequence
            One measurement per hypothesis, in the measurement model's units.
        measurement_model : MeasurementModel, optional
            This step's model (default: the bank's), e.g. bearings only when a level is
            missing.

        Returns
        -------
        int
            Status bits: 1 a covariance was repaired, 2 a hypothesis diverged.

        Raises
        ------
        FilterDivergence
            Every hypothesis diverged.
        """
        # predict and update fused per hypothesis (the same arithmetic as predict() then
        # update(); one loop, as this is the single-target tracker's hot path)
        meas = self.measurement_model if measurement_model is None else measurement_model
        f = self.filter
        status = 0
        for h, state in enumerate(self.states):
            if not self.alive[h]:
                continue
            rep = f.n_repairs
            try:
                upd, ll = f.update(f.predict(state, self.motion_model, dt, ctx), zs[h], meas,
                                   ctx)
            except FilterDivergence:
                self._kill(h)
                status |= 2
                continue
            status |= 1 if f.n_repairs > rep else 0
            self.states[h] = upd
            self.logw[h] += ll
        self.normalise()
        return status

    def prune(self) -> None:
        """Drop the live hypotheses whose weight is below ``prune_below`` (kept when the bank
        has one hypothesis)."""
        if self.prune_log is None or len(self.states) < 2:
            return
        drop = self.alive & (self.logw < self.prune_log)
        if drop.any():
            self.alive &= ~drop
            self.logw[drop] = -np.inf

    def _arrays(self) -> tuple[np.ndarray, np.ndarray]:
        X = np.ascontiguousarray([s.x for s in self.states], dtype=float)
        P = np.ascontiguousarray([s.P for s in self.states], dtype=float)
        return X, P

    def combine(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Combined state (eq. (12)), covariance (eq. (13)) and weights (eqs. (10)-(11))."""
        X, P = self._arrays()
        n = X.shape[1]
        x = np.empty(n)
        Pc = np.empty((n, n))
        w = np.empty(X.shape[0])
        kl.lr_combine(X, P, self.logw, self.alive, x, Pc, w)
        return x, Pc, w

    @property
    def weights(self) -> np.ndarray:
        """ω_k^h, eqs. (10)-(11)."""
        return self.combine()[2]

    def estimate(self) -> tuple[np.ndarray, np.ndarray]:
        """Combined state (eq. (12)) and covariance (eq. (13))."""
        x, P, _ = self.combine()
        return x, P

    def side_weight(self) -> float:
        """Summed weight of the live starboard hypotheses."""
        return float(np.exp(self.logw[self.alive & (self.sides == "starboard")]).sum())

    def estimate_side(self) -> tuple[np.ndarray, np.ndarray]:
        """The mixture (eqs. (12)-(13)) of the live hypotheses on the heavier side only; the
        two sides are not mixed (their mean would lie on the array's axis)."""
        on = self.alive.copy()
        if self.mirrored:
            stbd = self.sides == "starboard"
            on &= stbd if self.side_weight() >= 0.5 else ~stbd
        lw = np.where(on, self.logw, -np.inf)
        lw = lw - lw.max()
        lw -= math.log(np.exp(lw).sum())
        X, P = self._arrays()
        x = np.empty(X.shape[1])
        Pc = np.empty((X.shape[1], X.shape[1]))
        kl.lr_combine(X, P, lw, on, x, Pc, np.empty(X.shape[0]))
        return x, Pc


def normalise_floor(logw: np.ndarray, floor: float | None = None) -> np.ndarray:
    """Log-weights (n, H) of n banks normalised row by row (eqs. (10)-(11), the kernel
    :func:`~arrayproc.track.manage._kernels.lr_normalise`), then floored at ``floor``; returns
    the mixture log-likelihood ln Σ_h ω_{k−1}^h p_k^h of each row (the log-weights on entry)."""
    alive = np.ones(logw.shape[1], np.bool_)
    tot = np.empty(logw.shape[0])
    for i in range(logw.shape[0]):
        row = logw[i].copy()
        kl.lr_normalise(logw[i], alive)
        tot[i] = row[0] - logw[i, 0]
    if floor is not None:
        np.maximum(logw, floor, out=logw)
    return tot


class StackedBank:
    """H hypotheses per track on stacked tracks: the filter of a
    :class:`~arrayproc.track.manage.manager.TrackManager` whose tracks carry log-weights.

    A track's state interleaves its hypotheses: component i of hypothesis h sits at
    i·H + h (for [β, β̇] hypotheses, [β_0, β_1, β̇_0, β̇_1]); the covariance has no cross
    terms between hypotheses. Hypothesis h runs ``filt`` on its components and reads member
    h of each measurement (``members(Z)`` (m, H, k)), with the noise ``noise(Z)`` (m, k, k)
    handed to the model as the context's ``meas_cov``. Association scores each
    (track, measurement) pair by its best hypothesis, ln ω^h + ln N(ν_h; 0, S_h); the update
    feeds every hypothesis its member and reweights (eqs. (9)-(11)), the weights floored at
    ``floor`` (log).
    """

    def __init__(self, filt: StackedEKF, n_hypotheses: int,
                 members: Callable[[np.ndarray], np.ndarray],
                 noise: Callable[[np.ndarray], np.ndarray] | None = None,
                 floor: float | None = None) -> None:
        self.filt = filt
        self.n_hypotheses = int(n_hypotheses)
        self.members = members
        self.noise = noise
        self.floor = floor

    def _ctx(self, Z: np.ndarray, ctx: Any) -> Any:
        if self.noise is None:
            return ctx
        R = self.noise(Z)
        if ctx is None:
            return Context(np.zeros(4), meas_cov=R)
        return dataclasses.replace(ctx, meas_cov=R)

    def predict(self, X: np.ndarray, P: np.ndarray, dt: np.ndarray, ctx: Any = None
                ) -> tuple[np.ndarray, np.ndarray]:
        """Every hypothesis of every track predicted (the filter's motion model). The
        predicted covariance has no cross terms between hypotheses (a JPDA mixture of the
        previous scan made some: dropping them leaves each hypothesis its own PDA update)."""
        X, Pn = X.copy(), np.zeros_like(P)
        H = self.n_hypotheses
        for h in range(H):
            X[:, h::H], Pn[:, h::H, h::H] = self.filt.predict(
                X[:, h::H], np.ascontiguousarray(P[:, h::H, h::H]), dt, ctx)
        return X, Pn

    def _hypotheses(self, X: np.ndarray, P: np.ndarray, Z: np.ndarray, ctx: Any
                    ) -> tuple[list[np.ndarray], list[np.ndarray], np.ndarray]:
        H = self.n_hypotheses
        M = self.members(Z)
        hctx = self._ctx(Z, ctx)
        nus, Ss = [], []
        for h in range(H):
            nu, S = innovation_stacked(self.filt.measurement_model, X[:, h::H],
                                       np.ascontiguousarray(P[:, h::H, h::H]), M[:, h], hctx)
            nus.append(nu)
            Ss.append(S if S.ndim == 4 else np.broadcast_to(S[:, None], nu.shape + nu.shape[-1:]))
        ll = np.stack([-0.5 * (d2 + ld) for d2, ld in (mahalanobis(nu, S)
                                                        for nu, S in zip(nus, Ss, strict=True))],
                      -1)
        return nus, Ss, ll

    def innovation(self, X: np.ndarray, P: np.ndarray, Z: np.ndarray, ctx: Any = None,
                   W: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """ν (n, m, k) and S (n, m, k, k) of the best hypothesis of each pair (the largest
        ln ω^h + ln N(ν_h; 0, S_h))."""
        nus, Ss, ll = self._hypotheses(X, P, Z, ctx)
        score = ll if W is None else ll + W[:, None, :]
        best = np.argmax(score, axis=-1)
        ii = np.arange(best.shape[0])[:, None]
        jj = np.arange(best.shape[1])[None, :]
        return np.stack(nus, 0)[best, ii, jj], np.stack(Ss, 0)[best, ii, jj]

    def update(self, X: np.ndarray, P: np.ndarray, Z: np.ndarray, ctx: Any, idx: np.ndarray,
               W: np.ndarray | None = None
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Each hypothesis updated with its member of measurement ``idx``; weights by the
        likelihoods (eqs. (9)-(11)). Returns X, P, the mixture log-likelihood and W."""
        X, P = X.copy(), P.copy()
        H = self.n_hypotheses
        M = self.members(np.asarray(Z, float))
        hctx = self._ctx(np.asarray(Z, float), ctx)
        W = np.zeros((X.shape[0], H)) - math.log(H) if W is None else W.copy()
        for h in range(H):
            X[:, h::H], P[:, h::H, h::H], ll = update_stacked(
                self.filt.measurement_model, X[:, h::H],
                np.ascontiguousarray(P[:, h::H, h::H]), M[:, h], hctx, idx)
            W[:, h] += ll
        tot = normalise_floor(W, self.floor)
        return X, P, tot, W

    def dominant(self, X: np.ndarray, P: np.ndarray, W: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """State (n, dh) and covariance (n, dh, dh) of each track's heaviest hypothesis, and
        the normalised weights (n, H) (the per-side estimate)."""
        H = self.n_hypotheses
        best = np.argmax(W, axis=1)
        n = X.shape[0]
        Xh = np.stack([X[:, h::H] for h in range(H)], 1)[np.arange(n), best]
        Ph = np.stack([P[:, h::H, h::H] for h in range(H)], 1)[np.arange(n), best]
        w = np.exp(W)
        return Xh, Ph, w / w.sum(1, keepdims=True)
