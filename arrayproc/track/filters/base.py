"""What every filter shares: the divergence error and the component base."""

from __future__ import annotations

from arrayproc.track.base import Component

__all__ = ["FilterDivergence", "Filter"]


class FilterDivergence(ArithmeticError):
    """A filter's state or covariance became non-finite (the track is lost)."""


class Filter(Component):
    """A recursive filter: ``predict(state, motion_model, dt, ctx)`` and
    ``update(state, z, measurement_model, ctx) -> (state, log-likelihood)``; states are
    :class:`~arrayproc.track.state.GaussianState` or
    :class:`~arrayproc.track.state.ParticleState` (both expose ``x`` and ``P``)."""

    name = "filter"
    n_repairs: int = 0  # covariance repairs so far (Gaussian filters count them)
