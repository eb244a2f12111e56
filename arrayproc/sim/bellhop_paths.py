"""BELLHOP arrivals as the simulator's propagation paths (``multipath = "bellhop"``).

For every source depth BELLHOP (bellhopcxx, :func:`arrayproc.acoustics.tl.bellhop.
run_arrivals`) traces the eigenrays to the array depth on a range grid; the arrivals are
grouped into ray families (bounce counts and launch/arrival angle signs,
:func:`arrayproc.acoustics.tl.arrivals.family_tables`) whose delay τ(r) and complex amplitude
A(r)e^{iφ(r)} are linear in range between grid points. Each family is rendered by
:func:`arrayproc.sim._propagate_kernels.table_accumulate` with its own exact travel time per
sample and element (so its own Doppler), the phase applied through the Hilbert transform of
the source signal. Amplitudes and phases are those of the ray trace at ``freq``: exact for
tonals at that frequency, an approximation across a band. Element depth offsets from the
array depth are neglected (the table is for the array depth). The Hilbert transformer
(2·``HILBERT_HALF`` + 1 taps at the source rate 2·fs, Hann window) is accurate from about
fs/50 up to the simulator's band edge; a phase other than 0 or π is approximate below that.
"""

from __future__ import annotations

import numpy as np

from arrayproc.acoustics.tl.arrivals import family_tables
from arrayproc.acoustics.tl.bellhop import BellhopEnv, run_arrivals
from arrayproc.sim.scenario import BellhopSpec

HILBERT_HALF = 256  # taps each side of the FIR Hilbert transformer (source rate)


def environment(spec: BellhopSpec, c: float, src_depth: float, rcv_depth: float
                ) -> BellhopEnv:
    """The BELLHOP environment of the scenario's ``[propagation.bellhop]``."""
    ssp = spec.ssp if spec.ssp is not None else np.array([[0.0, c], [spec.depth, c]])
    # a uniform grid (the kernel indexes it) from one step out: BELLHOP has no range 0
    ranges = np.arange(1, int(np.ceil(spec.max_range / spec.range_step)) + 1) * spec.range_step
    return BellhopEnv(title="arrayproc scenario", freq_hz=spec.freq, ssp=ssp,
                      ssp_option="CVW", depth_m=spec.depth, bottom_speed=spec.bottom_speed,
                      bottom_density=spec.bottom_density, bottom_atten=spec.bottom_atten,
                      src_depths_m=(float(src_depth),), rcv_depths_m=np.array([rcv_depth]),
                      ranges_m=ranges, run_type="A", n_beams=spec.n_beams,
                      angles_deg=(-89.0, 89.0), box_depth_m=spec.depth * 1.01 + 1.0,
                      box_range_km=spec.max_range * 1.02 / 1000.0 + 0.01)


class FamilyPaths:
    """The ray-family tables of one source depth: ``tables`` (n_fam, n_r, 3), ``r0``, ``dr``,
    ``keys`` (surface bounces, bottom bounces, launch sign, arrival sign) per family."""

    def __init__(self, spec: BellhopSpec, c: float, src_depth: float, rcv_depth: float) -> None:
        arr = run_arrivals(environment(spec, c, src_depth, rcv_depth))[0]
        fams = family_tables(arr)
        self.keys = sorted(fams)
        self.tables = [np.ascontiguousarray(fams[k]) for k in self.keys]
        self.r0 = float(arr.ranges[0])
        self.dr = float(arr.ranges[1] - arr.ranges[0]) if arr.ranges.size > 1 else 1.0
        self.ranges = arr.ranges

    def delay(self, i: int, r: np.ndarray) -> np.ndarray:
        """Family i's delay (s) at horizontal ranges r (m), as the kernel reads it."""
        x = np.clip((np.asarray(r, float) - self.r0) / self.dr, 0, self.ranges.size - 1)
        return np.interp(x, np.arange(self.ranges.size), self.tables[i][:, 0])


def reference_delay(paths: FamilyPaths, i: int, ref_xy: np.ndarray, t: np.ndarray,
                    mover) -> np.ndarray:
    """τ with τ = τ_i(r_h(t − τ)) at the reference points (fixed-point, 10 steps)."""
    tau = paths.delay(i, np.hypot(*(ref_xy - mover.state3(t)[0][:, :2]).T))
    for _ in range(10):
        tau = paths.delay(i, np.hypot(*(ref_xy - mover.state3(t - tau)[0][:, :2]).T))
    return tau


def hilbert_fir() -> np.ndarray:
    """Odd-length FIR Hilbert transformer (2/(πn) for odd n, Hann-windowed)."""
    n = np.arange(-HILBERT_HALF, HILBERT_HALF + 1)
    h = np.zeros(n.size)
    odd = n % 2 != 0
    h[odd] = 2.0 / (np.pi * n[odd])
    return h * np.hanning(n.size + 2)[1:-1]


def quadrature(block, m0: int, m1: int, fir: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(s, ŝ) on source samples [m0, m1): the signal and its Hilbert transform, from a block
    ``HILBERT_HALF`` samples wider each side (so chunking never changes a value)."""
    x = block(m0 - HILBERT_HALF, m1 + HILBERT_HALF)
    q = np.convolve(x, fir, mode="valid")
    return (np.ascontiguousarray(x[HILBERT_HALF:HILBERT_HALF + (m1 - m0)]),
            np.ascontiguousarray(q))
