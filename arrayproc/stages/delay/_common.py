"""What the delay stages hand each other: ``DELAYS`` blocks (one row of delays each, with
:class:`~arrayproc.chain.domains.DelaysMeta`), declared in :mod:`arrayproc.chain.domains`."""

from __future__ import annotations

from arrayproc.chain.domains import DelaysMeta, Domain

#: Domain of a delays block: data (n_channels,) delays in s relative to the reference.
DELAYS = Domain.DELAYS

__all__ = ["DELAYS", "DelaysMeta"]
