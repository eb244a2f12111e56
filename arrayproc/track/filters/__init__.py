"""Recursive filters for any motion and measurement model: the Gaussian family (EKF, UKF, CKF,
GHF, SRF; L-R paper section IV) and the regularized particle filter (SPL paper section 4).

``FILTERS`` maps a configuration name to its class; :func:`make_filter` builds one from a
tracker TOML's ``filter`` and ``[tracker.params]``.
"""

from __future__ import annotations

from typing import Any

from arrayproc.errors import ConfigError
from arrayproc.track.filters.base import Filter, FilterDivergence
from arrayproc.track.filters.gaussian import CKF, EKF, GHF, SRF, UKF, GaussianFilter
from arrayproc.track.filters.particle import RPF

__all__ = ["Filter", "FilterDivergence", "GaussianFilter", "EKF", "UKF", "CKF", "GHF", "SRF",
           "RPF", "FILTERS", "make_filter"]

FILTERS: dict[str, type[Filter]] = {
    "ekf": EKF, "ukf": UKF, "ckf": CKF, "ghf": GHF, "srf": SRF, "rpf": RPF,
}


def make_filter(name: str, **params: Any) -> Filter:
    """Build a filter from its configuration name and parameters.

    Parameters
    ----------
    name : str
        A key of ``FILTERS``.
    **params
        The filter's declared parameters (e.g. ``alpha`` for the UKF, ``gh_order`` for the
        GHF, ``n_particles`` for the RPF).

    Returns
    -------
    Filter

    Raises
    ------
    ConfigError
        Unknown filter or bad parameter.

    Examples
    --------
    One EKF step on a bearing (the state is the target relative to the observer, x east,
    y north): the prior lies at 26.6 deg, the measurement says 36.9 deg, the update moves the
    estimate towards the measurement.

    >>> import numpy as np
    >>> from arrayproc import Bearing, ConstantVelocity, make_filter
    >>> from arrayproc.track.state import Context
    >>> ekf = make_filter("ekf")
    >>> ctx = Context(own=np.zeros(4))  # observer at rest at the origin
    >>> state = ekf.initialize([2000.0, 4000.0, 0.0, 0.0], np.diag([1e6, 1e6, 4.0, 4.0]))
    >>> state = ekf.predict(state, ConstantVelocity(q1=1e-4), 10.0, ctx)
    >>> state, loglik = ekf.update(state, np.radians(36.87), Bearing(sigma_deg=1.0), ctx)
    >>> bearing = np.degrees(np.arctan2(state.x[0], state.x[1]))
    >>> bool(26.6 < bearing < 36.9), state.P.shape
    (True, (4, 4))
    """
    try:
        cls = FILTERS[name]
    except KeyError:
        raise ConfigError(f"tracker: unknown filter {name!r} (one of {', '.join(FILTERS)})"
                          ) from None
    return cls(**params)
