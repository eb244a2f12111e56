"""Chain stages, in folders that follow the data path: ``condition`` (DFT filter), ``beamform``
(CBF, inverse beamforming, ETAM), ``passive`` (integration, BTR, LOFAR, bearings, band power),
``delay``, ``active`` and ``narrowband``.

Each stage module registers its stage types when imported; :func:`load_all` imports them all.
The engine (:mod:`arrayproc.chain`) knows none of them by name.
"""

from __future__ import annotations

import importlib
import pkgutil


def load_all() -> None:
    """Import every stage module, which registers its stage types with the chain registry."""
    for m in pkgutil.walk_packages(__path__, prefix=f"{__name__}."):
        if not m.name.rsplit(".", 1)[-1].startswith("_"):
            importlib.import_module(m.name)
