"""Left-right ambiguity resolution with parallel filters (L-R paper section III).

One hypothesis per member of the port/starboard bearing pair, weights from the measurement
likelihoods (eqs. (9)-(11)), combined estimate and covariance (eqs. (12)-(13)). Works with any
filter of :mod:`arrayproc.track.filters` (Gaussian or particle), any motion model and any
measurement model. The weights and the combination are the kernels
:func:`~arrayproc.track.manage._kernels.lr_normalise` and
:func:`~arrayproc.track.manage._kernels.lr_combine`, which the fused Monte Carlo kernel
(:func:`run_lr_batch`) uses too.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from arrayproc.errors import ConfigError
from arrayproc.track.filters.base import Filter, FilterDivergence
from arrayproc.track.filters.gaussian import EKF, SRF, GaussianFilter
from arrayproc.track.manage import _kernels as kl
from arrayproc.track.models.base import MeasurementModel, MotionModel
from arrayproc.track.models.motion import ConstantTurn, ConstantVelocity
from arrayproc.track.state import Context

__all__ = ["LRResolver", "run_lr_batch"]


class LRResolver:
    """Multi-hypothesis (two for a line array's pair) tracker with equal initial weights
    ω^h = 1/m (section III).

    Parameters
    ----------
    filt : Filter
        The filter every hypothesis runs.
    motion_model : MotionModel
    measurement_model : MeasurementModel
    states : sequence of states
        The initial state of each hypothesis.
    """

    def __init__(self, filt: Filter, motion_model: MotionModel,
                 measurement_model: MeasurementModel, states: Sequence[Any]) -> None:
        self.filter = filt
        self.motion_model = motion_model
        self.measurement_model = measurement_model
        self.states = list(states)
        m = len(self.states)
        self.logw = np.full(m, -math.log(m))
        self.alive = np.ones(m, dtype=np.bool_)

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
            This step's model (default: the resolver's), e.g. bearings only when a level is
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
        meas = self.measurement_model if measurement_model is None else measurement_model
        status = 0
        for h, state in enumerate(self.states):
            if not self.alive[h]:
                continue
            rep = self.filter.n_repairs
            try:
                pred = self.filter.predict(state, self.motion_model, dt, ctx)
                upd, ll = self.filter.update(pred, zs[h], meas, ctx)
            except FilterDivergence:
                self.alive[h] = False
                self.logw[h] = -np.inf
                status |= 2
                continue
            if self.filter.n_repairs > rep:
                status |= 1
            self.states[h] = upd
            self.logw[h] += ll
        if not kl.lr_normalise(self.logw, self.alive):
            raise FilterDivergence("lr: every hypothesis diverged")
        return status

    def combine(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Combined state (eq. (12)), covariance (eq. (13)) and weights (eqs. (10)-(11))."""
        X = np.ascontiguousarray([s.x for s in self.states], dtype=float)
        P = np.ascontiguousarray([s.P for s in self.states], dtype=float)
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


def fused_kind(filt: Filter) -> int:
    """The fused Monte Carlo kernel's code for a Gaussian filter (ConfigError for others)."""
    if isinstance(filt, SRF):
        return kl.KIND_SRF_EXACT if filt.likelihood == "exact" else kl.KIND_SRF
    if isinstance(filt, EKF):
        return kl.KIND_EKF
    if isinstance(filt, GaussianFilter):
        return kl.KIND_SP
    raise ConfigError(f"the fused L-R Monte Carlo runs Gaussian filters, not {filt.name!r}")


def run_lr_batch(filt: Filter, motion_model: MotionModel, sigma_rad: float,
                 times: np.ndarray, zs: np.ndarray, own: np.ndarray, prior: np.ndarray,
                 init_draws: np.ndarray, est: np.ndarray, wts: np.ndarray, Pfin: np.ndarray,
                 status: np.ndarray) -> None:
    """Fused L-R runs on bearings (the Monte Carlo fast path, GIL released).

    Parameters
    ----------
    filt : Filter
        A Gaussian filter (EKF, UKF, CKF, GHF, SRF).
    motion_model : MotionModel
        :class:`ConstantVelocity` or :class:`ConstantTurn`.
    sigma_rad : float
        Bearing noise σθ, rad.
    times : (K,) ndarray
        s.
    zs : (R, K, n_hyp) ndarray
        Bearings, rad; column h feeds hypothesis h.
    own : (K, 4) ndarray
        Observer states.
    prior : (7,) ndarray
        [r̄, σr, s̄, σs, σθ, σc, σψ] (:meth:`arrayproc.track.init.TrackPrior.as_array`).
    init_draws : (R, 3) ndarray
        Initial (range, speed, course offset) of each run's mean.
    est, wts, Pfin, status : ndarray
        Outputs (R, K, 4), (R, K, n_hyp), (R, n, n), (R,); see
        :func:`arrayproc.track.manage._kernels.run_montecarlo`.
    """
    if not isinstance(motion_model, (ConstantVelocity, ConstantTurn)):
        raise ConfigError("the fused L-R Monte Carlo supports the cv and ct models")
    n = motion_model.ndim
    kl.run_montecarlo(fused_kind(filt), zs.shape[2], times, zs, own, float(sigma_rad),
                      motion_model.q1, motion_model.q2, prior, init_draws,
                      *filt.kernel_points(n), n, est, wts, Pfin, status)
