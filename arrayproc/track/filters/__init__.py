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
    """
    try:
        cls = FILTERS[name]
    except KeyError:
        raise ConfigError(f"tracker: unknown filter {name!r} (one of {', '.join(FILTERS)})"
                          ) from None
    return cls(**params)
