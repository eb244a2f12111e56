"""Helpers shared by the passive stages (integrate, BTR, LOFAR, bearings): the power-block check,
snapshot times, the beam-axis columns of products and the beam-power to received-level
offset."""

from __future__ import annotations

import numpy as np

from arrayproc.chain import Stage
from arrayproc.chain.block import Block
from arrayproc.chain.domains import Domain
from arrayproc.dsp.windows import time_taper
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


def received_level_offset_db(b: Block, broadband: bool) -> float:
    """dB to subtract from a beam-power level (dB re 1 µPa², the thesis's unnormalised sums)
    to get the received level at a hydrophone of a plane wave from the beam's direction.

    Per CBF snapshot a tone of amplitude A on a bin gives |Y| = N_H·N_DFT·A/2 (window and
    shading of mean 1), so its mean square A²/2 is 2|Y|²/(N_H²·N_DFT²); a broadband wave's
    power per bin carries the window's mean square ⟨w²⟩ as well. Integration sums N_B
    snapshots (unless ``mean``), a synthetic aperture adds N_S snapshots coherently (×N_S²).
    """
    m = b.meta
    n_h = b.positions.shape[0]
    nfft = float(m.nfft)
    integ = m.integration
    n_b = 1 if (integ is None or integ.mean) else integ.snapshots
    n_s = m.synthetic.snapshots if m.synthetic is not None else 1
    off = 10 * np.log10(n_b * (n_h * nfft * n_s) ** 2 / 2.0)
    if broadband:
        off += 10 * np.log10(np.mean(time_taper(str(m.window), int(nfft)) ** 2))
    return float(off)
