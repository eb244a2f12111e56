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

from arrayproc.acoustics.tl.arrivals import Arrivals, family_tables
from arrayproc.acoustics.tl.bellhop import BellhopEnv, run_arrivals
from arrayproc.sim.scenario import BellhopSpec

HILBERT_HALF = 256  # taps each side of the FIR Hilbert transformer (source rate)


def environment(spec: BellhopSpec, c: float, src_depth: float,
                rcv_depth: float | list[float]) -> BellhopEnv:
    """The BELLHOP environment of the scenario's ``[propagation.bellhop]`` (receivers at one
    depth or at several, increasing)."""
    ssp = spec.ssp if spec.ssp is not None else np.array([[0.0, c], [spec.depth, c]])
    # a uniform grid (the kernel indexes it) from one step out: BELLHOP has no range 0
    ranges = np.arange(1, int(np.ceil(spec.max_range / spec.range_step)) + 1) * spec.range_step
    return BellhopEnv(title="arrayproc scenario", freq_hz=spec.freq, ssp=ssp,
                      ssp_option="CVW", depth_m=spec.depth, bottom_speed=spec.bottom_speed,
                      bottom_density=spec.bottom_density, bottom_atten=spec.bottom_atten,
                      src_depths_m=(float(src_depth),),
                      rcv_depths_m=np.atleast_1d(np.asarray(rcv_depth, float)),
                      ranges_m=ranges, run_type="A", n_beams=spec.n_beams,
                      angles_deg=(-89.0, 89.0), box_depth_m=spec.depth * 1.01 + 1.0,
                      box_range_km=spec.max_range * 1.02 / 1000.0 + 0.01)


class FamilyPaths:
    """The ray-family tables of one source depth: ``tables`` (n_fam, n_r, 3), ``r0``, ``dr``,
    ``keys`` (surface bounces, bottom bounces, launch sign, arrival sign) per family."""

    def __init__(self, spec: BellhopSpec, c: float, src_depth: float, rcv_depth: float) -> None:
        self._set(run_arrivals(environment(spec, c, src_depth, rcv_depth))[0], 0)

    @classmethod
    def from_arrivals(cls, arr: Arrivals, ir: int) -> FamilyPaths:
        """The families of receiver depth index ``ir`` of one BELLHOP arrivals run."""
        obj = cls.__new__(cls)
        obj._set(arr, ir)
        return obj

    def _set(self, arr: Arrivals, ir: int) -> None:
        fams = family_tables(arr, ir)
        self.keys = sorted(fams)
        self.tables = [np.ascontiguousarray(fams[k]) for k in self.keys]
        self.r0 = float(arr.ranges[0])
        self.dr = float(arr.ranges[1] - arr.ranges[0]) if arr.ranges.size > 1 else 1.0
        self.ranges = arr.ranges
        live = [t for t in self.tables if np.any(t[:, 1:] != 0.0)]
        #: (n_live, n_r, 3): the families with a non-zero amplitude somewhere, stacked
        self.stacked = (np.ascontiguousarray(np.stack(live)) if live
                        else np.zeros((0, self.ranges.size, 3)))

    def delay_span(self, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Smallest and largest delay (s) over the live families at horizontal ranges r (m)."""
        if self.stacked.shape[0] == 0:
            z = np.zeros(np.shape(r))
            return z, z
        x = np.clip((np.asarray(r, float) - self.r0) / self.dr, 0, self.ranges.size - 1)
        d = np.array([np.interp(x, np.arange(self.ranges.size), tab[:, 0])
                      for tab in self.stacked])
        return d.min(axis=0), d.max(axis=0)

    def delay(self, i: int, r: np.ndarray) -> np.ndarray:
        """Family i's delay (s) at horizontal ranges r (m), as the kernel reads it."""
        x = np.clip((np.asarray(r, float) - self.r0) / self.dr, 0, self.ranges.size - 1)
        return np.interp(x, np.arange(self.ranges.size), self.tables[i][:, 0])


class FamilyCache:
    """BELLHOP runs cached per source depth, receivers at every depth given (sorted), so one
    run per source depth serves every leg ending at those depths.

    Reciprocity: the Green's function of a point source is symmetric in source and receiver
    (G(z_a → z_b, r) = G(z_b → z_a, r), constant density in the water), so the leg from a
    projector at z_p to a scatterer at z_t is read from the run with its source at z_t and a
    receiver at z_p: one run per scatterer depth gives both legs of an echo.
    """

    def __init__(self, spec: BellhopSpec, c: float, rcv_depths: list[float]) -> None:
        self.spec = spec
        self.c = float(c)
        self.rcv_depths = sorted({float(z) for z in rcv_depths})
        self._runs: dict[float, list[FamilyPaths]] = {}

    def get(self, src_depth: float, rcv_depth: float) -> FamilyPaths:
        """The ray families from ``src_depth`` to ``rcv_depth`` (one of the cache's)."""
        zs = float(src_depth)
        if zs not in self._runs:
            arr = run_arrivals(environment(self.spec, self.c, zs, self.rcv_depths))[0]
            self._runs[zs] = [FamilyPaths.from_arrivals(arr, ir)
                              for ir in range(len(self.rcv_depths))]
        return self._runs[zs][self.rcv_depths.index(float(rcv_depth))]

    @property
    def n_runs(self) -> int:
        """BELLHOP runs made so far."""
        return len(self._runs)


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
