"""The multi-target tracker's composition: a :class:`~arrayproc.track.manage.manager.
TrackManager` from a stacked filter, an initiator and the configured parts (associator,
M-of-N confirmer, deleter)."""

from __future__ import annotations

from typing import Any

from arrayproc.track.manage.delete import DeletionRule
from arrayproc.track.manage.manager import Initiator, TrackManager

__all__ = ["compose_manager"]

def compose_manager(cfg: dict[str, Any], filt: Any, init: Initiator, pos: tuple[int, ...],
                    merge_d2: float | None = None) -> TrackManager:
    """The manager of a checked multi configuration ``cfg``
    (:func:`~arrayproc.track.multi.config.check_multi_config`) around the stacked filter
    ``filt`` and initiator ``init``; ``pos`` the state components of the deleter's duplicate
    and σ tests.

    Examples
    --------
    The parts a user can also put together by hand:

    >>> import numpy as np
    >>> from arrayproc.track.filters.stacked import StackedEKF
    >>> from arrayproc.track.manage.associate import GNN
    >>> from arrayproc.track.manage.delete import DeletionRule
    >>> from arrayproc.track.manage.initiate import MofN
    >>> from arrayproc.track.models.motion import ConstantVelocity
    >>> from arrayproc.track.models.position import Position
    >>> filt = StackedEKF(ConstantVelocity(q1=0.01, axes=3), Position(axes=3, sigma=2.0))
    >>> mgr = TrackManager(filt, lambda Z, t, ctx, j: (np.r_[Z[j], 0, 0, 0], 4.0 * np.eye(6)),
    ...                    GNN(gate_prob=0.999), confirm=MofN(3, 5),
    ...                    delete=DeletionRule(max_misses=5, pos=(0, 1, 2)))
    >>> mgr.step(0.0, np.array([[100.0, 200.0, 30.0]]))
    >>> len(mgr.tracks)
    1
    """
    hw = cfg.get("hit_window")
    window = {} if hw is None else {"window": int(hw[1]), "min_hits": int(hw[0])}
    return TrackManager(filt, init, association=cfg["association"], gate_prob=cfg["gate_prob"],
                        confirm=cfg["confirm"],
                        delete=DeletionRule(max_misses=cfg["max_misses"], **window, pos=pos,
                                            merge_d2=merge_d2),
                        pd=cfg["pd"], clutter_density=cfg["clutter_density"])
