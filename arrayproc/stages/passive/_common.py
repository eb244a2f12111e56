"""Helpers shared by the passive stages (integrate, BTR, LOFAR, bearings): the power-block check,
snapshot times and the beam-axis columns of products."""

from __future__ import annotations

import numpy as np

from arrayproc.chain import Stage
from arrayproc.chain.block import Block
from arrayproc.chain.domains import Domain
from arrayproc.errors import ConfigError


def beam_columns(beams: np.ndarray) -> dict[str, np.ndarray]:
    """Static beam-axis datasets for products: cone angles, or bearing and elevation."""
    b = np.asarray(beams, float)
    if b.ndim == 1:
        return {"cone_deg": b}
    return {"cone_deg": b[:, 0], "elevation_deg": b[:, 1]}


def snapshot_times(b: Block) -> np.ndarray:
    return np.asarray(b.meta.times, float)


def check_power_block(stage: Stage, b: Block) -> None:
    """Raise a ConfigError naming ``stage`` unless ``b`` is a power block from ``integrate``."""
    if b.domain is not Domain.POWER or np.iscomplexobj(b.data):
        raise ConfigError(f"stage {stage.name!r}: needs power blocks from 'integrate', "
                          f"got {b.domain}")
