"""Active sonar: pings from a projector towed with the array, echoes from moving targets,
clutter (static, or drifting with a random velocity), bottom features, boundary reverberation,
and the direct blast.

Geometry is exact (two retarded-time legs per sample and element, see
``arrayproc.sim._propagate_kernels.echo_accumulate``), so an echo from a target at range rate ṙ
is time-scaled by d = (c − ṙ)/(c + ṙ) (thesis eq. (4.8)) without any Doppler being added by
hand. Echo amplitude: A · 10^(TS/20) · g(r1) · g(r2) with A the pulse's peak amplitude at 1 m
(SL = RMS level of the carrier, dB re 1 µPa @ 1 m), TS the target strength (dB re 1 m²
equivalent, i.e. echo level at 1 m from the target relative to the incident level) and g the
loss law's amplitude gain of each leg. Optional thesis eq. (4.6) time distortion (α per
target) spreads the echo in Doppler.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from arrayproc.dsp.fracdelay import HALF_WIDTH, default_table
from arrayproc.sim._propagate_kernels import echo_accumulate, echo_accumulate_serial
from arrayproc.sim.bellhop_echo import BellhopEchoes
from arrayproc.sim.bellhop_paths import FamilyCache
from arrayproc.sim.motion import BodyOffsetMover, DriftMover, FixedMover, TrackMover
from arrayproc.sim.multipath import ImageMover, images, rough_exponent
from arrayproc.sim.propagation import LossLaw, PoseTrack, forward_time, grid_nodes, retarded_time
from arrayproc.sim.scenario import ActiveSpec, MultipathSpec, ReverbSpec
from arrayproc.sim.sources import tonal_amplitude

KEY_CLUTTER = 31
KEY_REVERB = 32
SERIAL_BELOW = 16384  # element-samples of an echo window below which the kernel runs serially


@dataclass
class Scatterer:
    name: str
    kind: str  # "target" | "highlight" | "clutter" | "feature" | "reverb"
    mover: object
    depth: float
    ts_db: float  # for "reverb": 10 log10(μ·A), A the area each scatterer stands for
    alpha: float = 0.0
    lambert: bool = False  # scattering ∝ sin θi · sin θs (Lambert's law), per ping geometry


class RowsMover:
    """Fixed points, one per row of the times asked for (a batch of static scatterers)."""

    is_static = True

    def __init__(self, positions: np.ndarray) -> None:
        self.positions = np.asarray(positions, float)

    def state3(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        n = np.atleast_1d(np.asarray(t)).size
        if n != self.positions.shape[0]:
            raise ValueError(f"RowsMover holds {self.positions.shape[0]} rows, asked {n}")
        z = np.zeros_like(self.positions)
        return self.positions, z, z


def reverb_scatterers(rv: ReverbSpec, seed: int, index: int) -> list[Scatterer]:
    """Boundary reverberation as random point scatterers, uniform over the area at the given
    density n (m⁻²), each standing for A = 1/n of boundary: σ_i = μ·A·sin θi·sin θs (Lambert's
    law), so the mean reverberant intensity is the sonar equation's
    SL − 2 TL + 10 log10(μ sin θi sin θs) + 10 log10(ensonified area)."""
    a = rv.area
    n = int(round(rv.density * (a[1] - a[0]) * (a[3] - a[2])))
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(KEY_REVERB, index)))
    xy = np.column_stack([rng.uniform(a[0], a[1], n), rng.uniform(a[2], a[3], n)])
    ts = rv.strength_db - 10 * np.log10(rv.density)
    return [Scatterer(f"reverb{index}.{i}", "reverb", FixedMover([x, y, rv.depth]), rv.depth,
                      float(ts), lambert=True) for i, (x, y) in enumerate(xy)]


class PingTrain:
    """The projector's emitted signal (Pa at 1 m) by absolute source-sample index: the direct
    blast is propagated like any passive source (each ping with its own waveform and level)."""

    def __init__(self, active: ActiveSim) -> None:
        self.a = active
        self.mover = active.projector
        self.depth = float(active.projector.state3(np.zeros(1))[0][0, 2])

    def block(self, m0: int, m1: int) -> np.ndarray:
        a = self.a
        t = np.arange(m0, m1) / a.fs_src
        out = np.zeros(t.size)
        for tp, name in zip(a.ping_times, a.ping_names):
            w = a.spec.waveforms[name]
            T = w.duration
            if tp + T < t[0] or tp > t[-1]:
                continue
            i0 = max(0, int(np.floor((tp - t[0]) * a.fs_src)))
            i1 = min(t.size, int(np.ceil((tp + T - t[0]) * a.fs_src)) + 1)
            out[i0:i1] += a.amps[name] * w(t[i0:i1] - tp)
        return out


class ActiveSim:
    """Pings, scatterers, echo windows and their truth for one scenario."""

    def __init__(self, spec: ActiveSpec, own: TrackMover, loss: LossLaw, c: float, fs: float,
                 fs_src: float, duration: float, seed: int, array_extent: float,
                 source_movers: dict[str, TrackMover],
                 multipath: MultipathSpec | None = None,
                 bellhop: FamilyCache | None = None) -> None:
        self.spec = spec
        self.multipath = multipath
        imgs = images(multipath)
        #: (receive-leg image, transmit-leg image) of every echo path, the direct one first
        self.path_pairs = [(ir, it) for ir in imgs for it in imgs]
        self.own = own
        self.loss = loss
        self.c = float(c)
        self.fs = float(fs)
        self.fs_src = float(fs_src)
        self.projector = BodyOffsetMover(own, spec.offset)
        #: echo paths over BELLHOP family pairs (multipath = "bellhop"), else image pairs
        self.bellhop = None if bellhop is None else BellhopEchoes(
            bellhop, float(own.depth), float(self.projector.state3(np.zeros(1))[0][0, 2]),
            spec.waveforms, fs_src)
        #: peak amplitude at 1 m of each waveform, from its source level
        self.amps = {n: tonal_amplitude(lv) for n, lv in spec.levels.items()}
        self.amp = self.amps[spec.schedule[0]]
        self.ping_times, self.ping_names = spec.pings(duration)
        #: waveform names in /active/waveforms order (sorted) and each ping's index into them
        self.names = sorted(spec.waveforms)
        self.ping_index = np.array([self.names.index(n) for n in self.ping_names], np.int64)
        self.ping_duration = np.array([spec.waveforms[n].duration for n in self.ping_names])
        # scatterers
        self.scatterers: list[Scatterer] = []
        for tg in spec.targets:
            mover = (source_movers[tg.source] if tg.source is not None
                     and tg.depth == source_movers[tg.source].depth
                     else TrackMover(tg.traj, tg.depth))
            if tg.length <= 0 or tg.highlights == 1:
                self.scatterers.append(Scatterer(tg.name, "target", mover, tg.depth, tg.ts_db,
                                                 tg.distortion))
                continue
            ts_h = tg.ts_db - 10 * np.log10(tg.highlights)  # total TS kept (incoherent sum)
            for k, x in enumerate(np.linspace(0.5 * tg.length, -0.5 * tg.length,
                                              tg.highlights)):
                self.scatterers.append(Scatterer(
                    f"{tg.name}.h{k}", "highlight", BodyOffsetMover(mover, [x, 0.0, 0.0]),
                    tg.depth, float(ts_h), tg.distortion))
        if spec.clutter is not None and spec.clutter.count > 0:
            cl = spec.clutter
            rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(KEY_CLUTTER,)))
            xy = np.column_stack([rng.uniform(cl.area[0], cl.area[1], cl.count),
                                  rng.uniform(cl.area[2], cl.area[3], cl.count)])
            ts = rng.normal(cl.ts_mean_db, cl.ts_std_db, cl.count)
            # drifting clutter: a horizontal velocity N(0, σ²) per axis, drawn after the
            # static draws (a static field is unchanged by the key's existence)
            vel = (rng.normal(0.0, cl.drift_speed_std, (cl.count, 2))
                   if cl.drift_speed_std > 0 else None)
            for i in range(cl.count):
                p = [xy[i, 0], xy[i, 1], cl.depth]
                mover = (FixedMover(p) if vel is None
                         else DriftMover(p, [vel[i, 0], vel[i, 1], 0.0]))
                self.scatterers.append(Scatterer(f"clutter{i}", "clutter", mover, cl.depth,
                                                 float(ts[i])))
        for ft in spec.features:
            for k, (x, y) in enumerate(ft.points):
                self.scatterers.append(Scatterer(f"{ft.name}.{k}", "feature",
                                                 FixedMover([x, y, ft.depth]), ft.depth,
                                                 ft.ts_db))
        for j, rv in enumerate(spec.reverberation):
            self.scatterers += reverb_scatterers(rv, seed, j)
        # pulse buffers with K+2 zero samples of margin each side, one per waveform
        pad = HALF_WIDTH + 2
        self.sig_t0 = -pad / self.fs_src
        self.sigs = {n: np.ascontiguousarray(w(
            self.sig_t0 + np.arange(int(np.ceil(w.duration * self.fs_src)) + 2 * pad + 1)
            / self.fs_src)) for n, w in spec.waveforms.items()}
        self.sig = self.sigs[spec.schedule[0]]
        self.table = default_table()
        self._windows(array_extent)

    def _windows(self, extent: float) -> None:
        """Arrival windows at the array and the truth of every (ping, scatterer) echo."""
        T = self.ping_duration
        c = self.c
        rows = {k: [] for k in ("ping", "target", "time", "delay_s", "range_rate_mps",
                                "level_db", "range_m", "t_start", "t_end")}
        tp = self.ping_times
        if tp.size == 0 or not self.scatterers:
            self.windows = {k: np.zeros(0) for k in rows}
            return
        pad = extent / c + (HALF_WIDTH + 3) / self.fs_src + 2.0 / self.fs
        if self.bellhop is not None:
            pad += self.bellhop.pad
        sl = np.array([self.spec.levels[n] for n in self.ping_names])
        static: dict[float, list[int]] = {}  # fixed scatterers by depth: one batch each
        for j, sc in enumerate(self.scatterers):
            if isinstance(sc.mover, FixedMover) and sc.alpha == 0.0:
                static.setdefault(sc.depth, []).append(j)
                continue
            self._echo_rows(rows, sc.mover, np.full(tp.size, j), np.arange(tp.size), tp, T,
                            sl + sc.ts_db, sc.depth, sc.alpha, pad)
        for depth, idx in static.items():
            idx = np.asarray(idx)
            pos = np.array([self.scatterers[j].mover.position for j in idx])
            ts_db = np.array([self.scatterers[j].ts_db for j in idx])
            n = tp.size
            self._echo_rows(rows, RowsMover(np.repeat(pos, n, axis=0)), np.repeat(idx, n),
                            np.tile(np.arange(n), idx.size), np.tile(tp, idx.size),
                            np.tile(T, idx.size), np.tile(sl, idx.size) + np.repeat(ts_db, n),
                            depth, 0.0, pad)
        self.windows = {k: np.concatenate(v) for k, v in rows.items()}
        order = np.lexsort((self.windows["target"], self.windows["ping"]))
        self.windows = {k: v[order] for k, v in self.windows.items()}

    def _echo_rows(self, rows: dict, mover: object, target: np.ndarray, ping: np.ndarray,
                   tp: np.ndarray, T: np.ndarray, level0: np.ndarray, depth: float,
                   alpha: float, pad: float) -> None:
        """Append the truth and window rows of echoes from ``mover`` (one row per emission
        time ``tp``; ``level0`` = SL + TS of each)."""
        c = self.c
        arr = []
        for te in (tp, tp + T):
            xp = self.projector.state3(te)[0]
            ts = forward_time(xp, te, mover, c)
            xt = mover.state3(ts)[0]
            tr = forward_time(xt, ts, self.own, c)
            arr.append((ts, tr))
        (ts, tr), (_, tr_end) = arr
        if self.bellhop is not None:
            tr_first, tr_last = self.bellhop.span(self.projector, self.own, mover, depth, tp,
                                                  T, tr, tr_end)
        else:
            tr_first, tr_last = self._path_span(mover, tp, T, tr, tr_end)
        pp, pv, _ = self.projector.state3(tp)
        tp3, tv, _ = mover.state3(ts)
        rp, rv, _ = self.own.state3(tr)
        r1v, r2v = tp3 - pp, tp3 - rp
        r1 = np.linalg.norm(r1v, axis=1)
        r2 = np.linalg.norm(r2v, axis=1)
        rr = 0.5 * (np.sum(r1v / r1[:, None] * (tv - pv), axis=1)
                    + np.sum(r2v / r2[:, None] * (tv - rv), axis=1))
        depth_r = float(self.own.depth)
        level = level0 - self.loss.tl_db(r1, depth, depth_r) - self.loss.tl_db(r2, depth,
                                                                                depth_r)
        rows["ping"].append(ping)
        rows["target"].append(target)
        rows["time"].append(tr)
        rows["delay_s"].append(tr - tp)
        rows["range_rate_mps"].append(rr)
        rows["level_db"].append(level)
        rows["range_m"].append(0.5 * (r1 + r2))
        rows["t_start"].append(tr_first - pad - alpha)
        rows["t_end"].append(tr_last + pad + alpha)

    def _path_span(self, mover: object, tp: np.ndarray, T: np.ndarray, tr: np.ndarray,
                   tr_end: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """First and last arrival times at the array over every echo path of each ping."""
        first, last = tr.copy(), tr_end.copy()
        c = self.c
        for ir, it in self.path_pairs[1:]:
            proj = ImageMover(self.projector, it)
            for te, is_end in ((tp, False), (tp + T, True)):
                ts = forward_time(proj.state3(te)[0], te, mover, c)
                xt = ImageMover(mover, ir).state3(ts)[0]
                ta = forward_time(xt, ts, self.own, c)
                first = np.minimum(first, ta) if not is_end else first
                last = np.maximum(last, ta) if is_end else last
        return first, last

    def truth(self) -> dict:
        """``/truth/pings`` (time, waveform name, source level) and ``/truth/echoes``
        (docs/formats.md) plus scatterer data; attrs: the first scheduled waveform's parameters (the
        only one's in the single-waveform form), the schedule and the projector offset."""
        w = self.windows
        wf = self.spec.waveform
        reverb = np.array([sc.kind == "reverb" for sc in self.scatterers] + [False])
        keep = ~reverb[w["target"].astype(np.int64)] if w["target"].size else np.zeros(0, bool)
        return {
            "pings": {"time": self.ping_times.astype(float),
                      "waveform": np.array(self.ping_names, dtype="S"),
                      "level_db": np.array([self.spec.levels[n] for n in self.ping_names],
                                           float)},
            # every echo but the reverberation scatterers' (those are in /truth/scatterers)
            "echoes": {k: (w[src][keep].astype(np.int64) if k in ("ping", "target")
                           else w[src][keep])
                       for k, src in (("ping", "ping"), ("target", "target"), ("time", "time"),
                                      ("delay_s", "delay_s"),
                                      ("range_rate_mps", "range_rate_mps"),
                                      ("level_db", "level_db"), ("range_m", "range_m"))},
            "scatterers": {"name": np.array([s.name for s in self.scatterers], dtype="S"),
                           "kind": np.array([s.kind for s in self.scatterers], dtype="S"),
                           "ts_db": np.array([s.ts_db for s in self.scatterers]),
                           "depth": np.array([s.depth for s in self.scatterers]),
                           "position0": np.array([s.mover.state3(np.zeros(1))[0][0]
                                                  for s in self.scatterers]).reshape(-1, 3)},
        }, {"waveform": wf.kind, "duration": wf.duration, "fc": wf.fc, "f0": wf.f0,
            "f1": wf.f1, "bits": int(wf.sequence.size), "taper": wf.taper,
            "level_db": self.spec.levels[self.spec.schedule[0]], "offset": self.spec.offset,
            "schedule": ",".join(self.spec.schedule)}

    def recording_active(self) -> tuple:
        """Arguments of :meth:`arrayproc.io.recording.RecordingWriter.set_active`: the ping
        schedule and every replica as a real sonar recording carries them (docs/formats.md),
        each replica sampled at the recording's rate (unit peak, the transmitted taper) and
        stored under its scenario name; each ping's index into the sorted names."""
        reps = {}
        for name in self.names:
            wf = self.spec.waveforms[name]
            if wf.kind == "hfm":
                fc, bw = 0.5 * (wf.f0 + wf.f1), abs(wf.f1 - wf.f0)
            else:
                fc, bw = wf.fc, wf.bandwidth
            attrs = {"kind": wf.kind, "fc": float(fc), "bandwidth": float(bw),
                     "duration": float(wf.duration), "taper": float(wf.taper),
                     "level_db": float(self.spec.levels[name])}
            if wf.kind == "bpsk":
                attrs["bits"] = int(wf.sequence.size)
            if wf.kind == "hfm":
                attrs.update(f0=float(wf.f0), f1=float(wf.f1))
            reps[name] = (wf(np.arange(int(np.ceil(wf.duration * self.fs)) + 1) / self.fs),
                          attrs)
        return (self.ping_times.astype(float), self.ping_index.copy(), reps,
                np.asarray(self.spec.offset, float))

    def render(self, out: np.ndarray, k0: int, t: np.ndarray, pose: PoseTrack,
               body: np.ndarray) -> None:
        """Add every echo overlapping the chunk (samples k0 …, times ``t``) to ``out``."""
        if self.windows["ping"].size == 0 or t.size == 0:
            return
        w = self.windows
        t0, t1 = t[0], t[-1]
        hit = np.flatnonzero((w["t_start"] <= t1) & (w["t_end"] >= t0))
        dt = t[1] - t[0] if t.size > 1 else 1.0 / self.fs
        for i in hit:
            i0 = max(0, int(np.ceil((w["t_start"][i] - t0) / dt)))
            i1 = min(t.size, int(np.floor((w["t_end"][i] - t0) / dt)) + 1)
            if i1 <= i0:
                continue
            sc = self.scatterers[int(w["target"][i])]
            k = int(w["ping"][i])
            tp = float(self.ping_times[k])
            name = self.ping_names[k]
            pw = pose.window(i0, i1)
            geo = self._lambert(sc, tp, float(w["time"][i])) if sc.lambert else 1.0
            if self.bellhop is not None:
                self.bellhop.render(out, i0, t[i0:i1], k0 + i0, self.fs, pw, body,
                                    self.projector, self.own, sc, tp, name,
                                    float(self.ping_duration[k]), self.c,
                                    geo * self.amps[name] * 10 ** (sc.ts_db / 20.0))
                continue
            for ir, it in self.path_pairs:
                self._render_path(out, k0, i0, i1, t[i0:i1], pw, body, sc, tp, name, ir, it,
                                  geo)

    def _lambert(self, sc: Scatterer, tp: float, ta: float) -> float:
        """√(sin θi · sin θs): Lambert's law amplitude factor of a boundary scatterer, from the
        projector at the ping time and the array reference point at the echo's arrival."""
        xs = sc.mover.state3(np.zeros(1))[0][0]
        xp = self.projector.state3(np.array([tp]))[0][0]
        xr = self.own.state3(np.array([ta]))[0][0]
        si = abs(xs[2] - xp[2]) / max(np.linalg.norm(xs - xp), 1e-9)
        ss = abs(xs[2] - xr[2]) / max(np.linalg.norm(xs - xr), 1e-9)
        return float(np.sqrt(si * ss))

    def _render_path(self, out: np.ndarray, k0: int, i0: int, i1: int, tw: np.ndarray,
                     pw: PoseTrack, body: np.ndarray, sc: Scatterer, tp: float, name: str,
                     ir: object, it: object, geo: float = 1.0) -> None:
        """One echo path: transmit leg by image ``it`` of the projector, receive leg by image
        ``ir`` of the scatterer (samples i0 … i1 of the chunk starting at k0)."""
        tgt = ImageMover(sc.mover, ir)
        proj = ImageMover(self.projector, it)
        # expansion points on the absolute grid (exact there), interpolated
        tg = grid_nodes(k0 + i0, k0 + i1, self.fs)
        ts_g = tg - retarded_time(self.own.state3(tg)[0], tg, tgt, self.c)
        te_g = ts_g - retarded_time(sc.mover.state3(ts_g)[0], ts_g, proj, self.c)
        ts = np.interp(tw, tg, ts_g)
        te = np.interp(tw, tg, te_g)
        tpos, tvel, tacc = tgt.state3(ts)
        ppos, pvel, pacc = proj.state3(te)
        w = np.ones(tw.size)
        mode, r_t, gtab, g0, gdr = self.loss.kernel_args(sc.depth, float(self.own.depth))
        kernel = echo_accumulate if tw.size * body.shape[0] > SERIAL_BELOW else \
            echo_accumulate_serial
        kernel(out, i0, ts, tpos, tvel, tacc, te, ppos, pvel, pacc, tw, pw.rpos,
                        pw.rdepth, pw.sin_h, pw.cos_h, pw.lateral, body, self.c,
                        self.sigs[name], tp, self.sig_t0, self.fs_src, self.table, mode,
                        r_t, gtab, g0, gdr,
                        geo * ir.coef * it.coef * self.amps[name] * 10 ** (sc.ts_db / 20.0),
                        sc.alpha, self.spec.waveforms[name].duration, w, pw.epos,
                        -ir.s * ir.a, ir.s, rough_exponent(self.multipath, ir, self.c),
                        rough_exponent(self.multipath, it, self.c))
