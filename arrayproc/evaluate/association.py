"""Contacts against the simulator's echo truth: which truth echo each detection is.

Nearest-in-range association inside a range and cone gate, per ping; the echo truth comes from
:func:`arrayproc.io.truth.echo_truth`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["associate"]


def associate(contacts: dict, truth: dict, range_gate: float, cone_gate: float
              ) -> np.ndarray:
    """For each contact, the index of the nearest-in-range truth echo of the same ping within
    ``range_gate`` m and ``cone_gate`` deg, else -1."""
    out = np.full(np.asarray(contacts["range_m"]).size, -1, int)
    for i, (p, r, c) in enumerate(zip(contacts["ping"], contacts["range_m"],
                                      contacts["cone_deg"])):
        tr = truth["range_array_m"]
        m = np.flatnonzero((truth["ping"] == p) & (np.abs(tr - r) <= range_gate)
                           & (np.abs(truth["cone_deg"] - c) <= cone_gate))
        if m.size:
            out[i] = int(m[np.argmin(np.abs(tr[m] - r))])
    return out
