"""Active echoes over BELLHOP eigenrays (``multipath = "bellhop"`` with ``[active]``).

Each echo path is a pair of ray families (:mod:`arrayproc.sim.bellhop_paths`): one from the
projector to the scatterer, one from the scatterer to the array, with delay τ₁ + τ₂ and
complex amplitude A₁A₂ (phases added), times the scatterer's 10^(TS/20) and the pulse's peak
amplitude, rendered with each leg's exact travel time per sample and element
(:func:`arrayproc.sim._echo_table_kernels.echo_table_accumulate`), as the image-source pairs
are. One BELLHOP run per scatterer depth (source at the scatterer, receivers at the array's
and the projector's depths) serves both legs, the transmit leg by reciprocity
(:class:`arrayproc.sim.bellhop_paths.FamilyCache`). The phase is applied through the pulse's
Hilbert transform (the passive BELLHOP mode's FIR, so the same limits apply); element depth
offsets from the array depth are neglected.
"""

from __future__ import annotations

import numpy as np

from arrayproc.dsp.fracdelay import HALF_WIDTH, default_table
from arrayproc.sim._echo_table_kernels import (
    echo_table_accumulate,
    echo_table_accumulate_serial,
)
from arrayproc.sim.bellhop_paths import (
    HILBERT_HALF,
    FamilyCache,
    FamilyPaths,
    hilbert_fir,
    quadrature,
)
from arrayproc.sim.propagation import N_ITER, PoseTrack, grid_nodes, retarded_time

SERIAL_BELOW = 16384  # element-sample-pairs of an echo below which the kernel runs serially


def _live_delay(fam: FamilyPaths, m: int, r: np.ndarray) -> np.ndarray:
    """Delay (s) of live family m at horizontal ranges r, NaN where its amplitude is zero."""
    tab = fam.stacked[m]
    x = np.clip((np.asarray(r, float) - fam.r0) / fam.dr, 0, fam.ranges.size - 1)
    grid = np.arange(fam.ranges.size)
    amp = np.abs(np.interp(x, grid, tab[:, 1])) + np.abs(np.interp(x, grid, tab[:, 2]))
    return np.where(amp > 0, np.interp(x, grid, tab[:, 0]), np.nan)


def _forward(fam: FamilyPaths, m: int, emit_xy: np.ndarray, t_emit: np.ndarray,
             mover: object) -> np.ndarray:
    """Arrival time at ``mover`` of family m emitted at ``t_emit`` from ``emit_xy`` (n, 2):
    t_a = t_e + τ_m(r_h(t_a)), fixed-point (NaN where the family is absent)."""
    def arrival(ta: np.ndarray) -> np.ndarray:
        xy = mover.state3(ta)[0][:, :2]
        return t_emit + _live_delay(fam, m, np.hypot(*(xy - emit_xy).T))

    ta = arrival(t_emit)
    if not getattr(mover, "is_static", False):
        for _ in range(N_ITER):
            ta = arrival(np.where(np.isfinite(ta), ta, t_emit))
    return ta


def _extreme(values: list[np.ndarray], fn: object, fallback: np.ndarray) -> np.ndarray:
    """Element-wise nanmin/nanmax over the families (``fallback`` where none is present)."""
    if not values:
        return fallback.copy()
    v = np.vstack(values)
    ok = np.isfinite(v).any(axis=0)
    out = fallback.copy()
    out[ok] = fn(v[:, ok], axis=0)
    return out


class BellhopEchoes:
    """Echo windows and rendering over BELLHOP family pairs for one active scenario."""

    def __init__(self, cache: FamilyCache, rcv_depth: float, proj_depth: float,
                 waveforms: dict, fs_src: float) -> None:
        self.cache = cache
        self.rcv_depth = float(rcv_depth)
        self.proj_depth = float(proj_depth)
        self.fs_src = float(fs_src)
        #: extra window margin each side (s): the Hilbert transform's support
        self.pad = HILBERT_HALF / self.fs_src
        self.table = default_table()
        fir = hilbert_fir()
        self.pulses = {}  # name -> (s, ŝ, pulse time of sample 0)
        for name, w in waveforms.items():
            m0 = -(HALF_WIDTH + 2 + HILBERT_HALF)
            m1 = int(np.ceil(w.duration * self.fs_src)) + HALF_WIDTH + 3 + HILBERT_HALF
            s, q = quadrature(lambda a, b, w=w: w(np.arange(a, b) / self.fs_src), m0, m1, fir)
            self.pulses[name] = (s, q, m0 / self.fs_src)

    def legs(self, depth: float) -> tuple[FamilyPaths, FamilyPaths]:
        """(receive, transmit) families of a scatterer at ``depth``: scatterer → array, and
        projector → scatterer read by reciprocity from the same run."""
        return (self.cache.get(depth, self.rcv_depth),
                self.cache.get(depth, self.proj_depth))

    def span(self, projector: object, own: object, mover: object, depth: float,
             tp: np.ndarray, T: np.ndarray, tr: np.ndarray, tr_end: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray]:
        """First and last arrival times at the array reference point over every family pair
        (the arrival is monotonic in the scattering time for subsonic motion, so the earliest
        scattering gives the earliest arrival on every receive family); the straight-path
        arrivals ``tr``/``tr_end`` where no family reaches."""
        recv, trans = self.legs(depth)
        out = []
        for te, fn, fb in ((tp, np.nanmin, tr), (tp + T, np.nanmax, tr_end)):
            xp = projector.state3(te)[0][:, :2]
            ts = _extreme([_forward(trans, i, xp, te, mover)
                           for i in range(trans.stacked.shape[0])], fn, fb)
            xt = mover.state3(ts)[0][:, :2]
            out.append(_extreme([_forward(recv, j, xt, ts, own)
                                 for j in range(recv.stacked.shape[0])], fn, fb))
        return out[0], out[1]

    def render(self, out: np.ndarray, i0: int, tw: np.ndarray, k_abs: int, fs: float,
               pw: PoseTrack, body: np.ndarray, projector: object, own: object, sc: object,
               tp: float, name: str, T: float, c: float, scale: float) -> None:
        """One echo (ping at ``tp`` with waveform ``name``, scatterer ``sc``) on the chunk
        samples i0 … i0 + len(tw) (absolute index ``k_abs`` of the first)."""
        recv, trans = self.legs(sc.depth)
        if recv.stacked.shape[0] == 0 or trans.stacked.shape[0] == 0:
            return
        # reference scattering and emission times on the absolute grid (straight paths),
        # the emission time kept inside the pulse (every contributing emission lies there)
        tg = grid_nodes(k_abs, k_abs + tw.size, fs)
        ts_g = tg - retarded_time(own.state3(tg)[0], tg, sc.mover, c)
        te_g = ts_g - retarded_time(sc.mover.state3(ts_g)[0], ts_g, projector, c)
        ts = np.interp(tw, tg, ts_g)
        te = np.clip(np.interp(tw, tg, te_g), tp, tp + T)
        tpos, tvel, tacc = sc.mover.state3(ts)
        ppos, pvel, pacc = projector.state3(te)
        s, q, t0 = self.pulses[name]
        work = tw.size * body.shape[0] * recv.stacked.shape[0] * trans.stacked.shape[0]
        kernel = echo_table_accumulate if work > SERIAL_BELOW else echo_table_accumulate_serial
        kernel(out, i0, ts, tpos, tvel, tacc, te, ppos, pvel, pacc, tw, pw.rpos, pw.rdepth,
               pw.sin_h, pw.cos_h, pw.lateral, body, pw.epos, s, q, tp, t0, self.fs_src,
               self.table, recv.stacked, trans.stacked, recv.r0, recv.dr, scale, sc.alpha, T)


def scatterer_range(spec: object, sources: list, t: np.ndarray, ref_xy: np.ndarray,
                    duration: float) -> float:
    """Largest horizontal distance (m) from the array reference points ``ref_xy`` (at times
    ``t``) to any scatterer of an ``[active]`` spec: targets along their tracks (plus half
    their length), clutter, reverberation and feature areas (drifting clutter 5σ·duration
    beyond its area): the range the BELLHOP arrivals must cover for the echoes."""
    from arrayproc.sim.motion import TrackMover

    far = 0.0
    by_name = {sp.name: sp for sp in sources}
    for tg in spec.targets:
        traj = tg.traj if tg.traj is not None else by_name[tg.source].traj
        xy = TrackMover(traj, tg.depth).state3(t)[0][:, :2]
        far = max(far, float(np.max(np.hypot(*(xy - ref_xy).T))) + 0.5 * tg.length)
    boxes = [(r.area, 0.0) for r in spec.reverberation]
    if spec.clutter is not None and spec.clutter.count > 0:
        boxes.append((spec.clutter.area, 5.0 * spec.clutter.drift_speed_std * duration))
    pts = [np.asarray(f.points, float).reshape(-1, 2) for f in spec.features]
    for a, grow in boxes:
        pts.append(np.array([[a[0] - grow, a[2] - grow], [a[0] - grow, a[3] + grow],
                             [a[1] + grow, a[2] - grow], [a[1] + grow, a[3] + grow]]))
    for p in pts:
        d = np.hypot(p[None, :, 0] - ref_xy[:, None, 0], p[None, :, 1] - ref_xy[:, None, 1])
        far = max(far, float(d.max()))
    return far
