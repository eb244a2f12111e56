"""Left-right ambiguity resolution with parallel filters (L-R paper section III).

One hypothesis per member of the port/starboard bearing pair, weights from the measurement
likelihoods (eqs. (9)-(11)), combined estimate and covariance (eqs. (12)-(13)):
:class:`LRResolver` is the hypothesis bank of :mod:`arrayproc.track.manage.bank` (any filter of
:mod:`arrayproc.track.filters`, Gaussian or particle, any motion and measurement model); this
module adds the fused Monte Carlo fast path. The weights and the combination are the kernels
:func:`~arrayproc.track.manage._kernels.lr_normalise` and
:func:`~arrayproc.track.manage._kernels.lr_combine`, which the fused Monte Carlo kernel
(:func:`run_lr_batch`) uses too.
"""

from __future__ import annotations

import numpy as np

from arrayproc.errors import ConfigError
from arrayproc.track.filters.base import Filter
from arrayproc.track.filters.gaussian import EKF, SRF, GaussianFilter
from arrayproc.track.manage import _kernels as kl
from arrayproc.track.manage.bank import HypothesisBank
from arrayproc.track.models.base import MotionModel
from arrayproc.track.models.motion import ConstantTurn, ConstantVelocity

__all__ = ["LRResolver", "HypothesisBank", "run_lr_batch"]


#: The L-R paper's parallel filters are the hypothesis bank (the name the papers' code uses).
LRResolver = HypothesisBank


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
