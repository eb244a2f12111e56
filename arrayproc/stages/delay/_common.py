"""What the delay stages hand each other: a ``delays`` block (one row of delays).

The chain's domain table (:mod:`arrayproc.chain.domains`) has no entry for delays yet; the
``tde`` stage yields blocks whose ``domain`` is :data:`DELAYS` and whose ``meta`` is a
:class:`DelaysMeta`, and the ``localise`` stage accepts exactly those.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Domain tag of a delays block: data (n_channels,) delays in s relative to the reference.
DELAYS = "delays"


@dataclass(frozen=True)
class DelaysMeta:
    """One row of delays with what localisation needs.

    Attributes
    ----------
    time : float
        Time of the row, s since the recording start.
    sigma, corr : (n_ch,) ndarray
        Standard deviation (s) and normalised peak correlation of each delay.
    reference : int
        Reference channel.
    elements : (n_ch, 3) ndarray
        Element positions in the world frame (x east, y north, z down), m.
    sound_speed : float
        m/s.
    event : int
        Detection number, or −1 for a regular snapshot.
    """

    time: float
    sigma: np.ndarray
    corr: np.ndarray
    reference: int
    elements: np.ndarray
    sound_speed: float
    event: int = -1
