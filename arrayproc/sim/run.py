"""Scenario → recording, streamed in chunks (``arrayproc simulate``).

Each output chunk [k0, k1) is computed from absolute sample indices only (array pose, exact
retarded times, source signals and noise frames keyed by index), so memory is bounded by the
chunk and the bytes do not depend on the chunk size.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from arrayproc.dsp.fracdelay import HALF_WIDTH, OVERSAMPLING, default_table
from arrayproc.errors import ConfigError
from arrayproc.io.recording import RecordingWriter
from arrayproc.sim._propagate_kernels import oneway_accumulate, table_accumulate
from arrayproc.sim.active import ActiveSim, PingTrain
from arrayproc.sim.bellhop_echo import scatterer_range
from arrayproc.sim.bellhop_paths import FamilyCache, hilbert_fir, quadrature, reference_delay
from arrayproc.sim.motion import BodyOffsetMover, TrackMover
from arrayproc.sim.multipath import (
    ImageMover,
    images,
    path_sin_grazing,
    rough_exponent,
    roughness_factor,
)
from arrayproc.sim.noise import ambient_noise
from arrayproc.sim.propagation import LossLaw, PoseTrack, grid_nodes, retarded_time
from arrayproc.sim.scenario import Scenario, load_scenario
from arrayproc.sim.sources import SourceSignal
from arrayproc.sim.yaw import GaussMarkovYaw

KEY_POSITION_ERROR = 41
KEY_LATERAL = 42
KEY_YAW = 43


class Simulator:
    """Renders a :class:`Scenario` chunk by chunk: ``render(k0, k1)`` → (n, ch) float32."""

    def __init__(self, scen: Scenario, warn: Callable[[str], None] | None = None) -> None:
        self.s = scen
        self.warn = warn or (lambda msg: None)
        self.fs = scen.fs
        self.fs_src = OVERSAMPLING * scen.fs
        self.c = scen.sound_speed
        self.n_samples = int(round(scen.duration * scen.fs))
        seed = scen.seed
        arr = scen.array
        self.nominal = arr.positions
        self.body = arr.positions.copy()
        if arr.position_error_std > 0:
            rng = np.random.default_rng(np.random.SeedSequence(seed,
                                                               spawn_key=(KEY_POSITION_ERROR,)))
            self.body = self.body + rng.normal(0.0, arr.position_error_std, self.body.shape)
        self.body = np.ascontiguousarray(self.body)
        self.n_channels = self.body.shape[0]
        self.n_snap = int(np.ceil(scen.duration / arr.lateral_snapshot)) + 1
        if arr.lateral_std > 0:
            rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(KEY_LATERAL,)))
            self.lateral_offsets = rng.normal(0.0, arr.lateral_std, self.n_snap)
        else:
            self.lateral_offsets = np.zeros(self.n_snap)
        self.yaw = (GaussMarkovYaw(arr.yaw_std, arr.yaw_time, scen.duration,
                                   np.random.SeedSequence(seed, spawn_key=(KEY_YAW,)))
                    if arr.yaw_std > 0 else None)
        self.extent = float(np.max(np.linalg.norm(self.body, axis=1))
                            + np.max(np.abs(self.lateral_offsets)))
        self.own = TrackMover(scen.ownship, arr.depth)
        self.loss = LossLaw(scen.propagation)
        self.images = images(scen.propagation.multipath)
        self.table = default_table()
        # passive sources (and the tow ship)
        self.sources: list[tuple[object, SourceSignal | PingTrain, float]] = []
        movers: dict[str, TrackMover] = {}
        mean_speed = self._mean_own_speed()
        for i, sp in enumerate(scen.sources):
            if sp.kind == "towship":
                if mean_speed > 0:  # on the array's own track, `distance` m ahead
                    mover = TrackMover(scen.ownship, sp.depth, lead=sp.lead / mean_speed)
                else:  # static array: along its heading
                    mover = BodyOffsetMover(self.own, [sp.lead, 0.0, sp.depth - arr.depth])
            else:
                mover = TrackMover(sp.traj, sp.depth)
                movers[sp.name] = mover
            self.sources.append((mover, SourceSignal(sp, mover, self.fs_src, seed, i), sp.depth))
        self.bellhop = None  # source depth -> BELLHOP ray families
        self.bellhop_runs = None  # BELLHOP runs per source depth (passive and echoes)
        if scen.propagation.bellhop is not None:
            bh = scen.propagation.bellhop
            if bh.max_range is None:  # every source's farthest horizontal range, with margin
                bh.max_range = self._max_range()
                bh.range_step = max(bh.range_step, bh.max_range / 20000)
            rcv = [float(arr.depth)]
            if scen.active is not None:  # the projector's depth: the echoes' transmit legs
                rcv.append(float(arr.depth + scen.active.offset[2]))
            self.bellhop_runs = FamilyCache(bh, self.c, rcv)
            self.bellhop = {float(d): self.bellhop_runs.get(float(d), float(arr.depth))
                            for d in sorted({float(x[2]) for x in self.sources})}
            self._hilbert = hilbert_fir()
        self.noise = (ambient_noise(scen.noise, self.fs, self.n_channels, seed)
                      if scen.noise is not None else None)
        self.active = None
        if scen.active is not None:
            self.active = ActiveSim(scen.active, self.own, self.loss, self.c, self.fs,
                                    self.fs_src, scen.duration, seed, self.extent, movers,
                                    scen.propagation.multipath, self.bellhop_runs)
            if scen.active.direct:
                pt = PingTrain(self.active)
                self.sources.append((pt.mover, pt, pt.depth))
                if self.bellhop is not None:
                    self.bellhop[pt.depth] = self.bellhop_runs.get(pt.depth, float(arr.depth))
        self._check()

    def _max_range(self) -> float:
        """Largest horizontal source-to-array distance over the run (and the 10 s before it,
        for retarded times), × 1.2 + 100 m: the range the BELLHOP arrivals must cover."""
        t = np.linspace(-10.0, self.s.duration, 512)
        ref = self.own.state3(t)[0][:, :2]
        far = max((float(np.max(np.hypot(*(m.state3(t)[0][:, :2] - ref).T)))
                   for m, _, _ in self.sources), default=100.0)
        if self.s.active is not None:  # every scatterer's, for the echoes
            far = max(far, scatterer_range(self.s.active, self.s.sources, t, ref,
                                           self.s.duration))
        return 1.2 * far + self.extent + 100.0

    def _mean_own_speed(self) -> float:
        segs = self.s.ownship.segments
        dur = sum(sg.duration for sg in segs)
        if not segs:
            return 0.0
        if dur <= 0:
            return float(segs[-1].speed)
        return float(sum(sg.speed * sg.duration for sg in segs) / dur)

    def _check(self) -> None:
        """Warnings for physically dubious set-ups (not errors)."""
        t = np.linspace(0, self.s.duration, 64)
        ref = self.own.state3(t)[0]
        for mover, sig, _ in self.sources:
            d = np.linalg.norm(mover.state3(t)[0] - ref, axis=1)
            if np.min(d) < 2 * self.extent + 1.0:
                name = getattr(getattr(sig, "spec", None), "name", "projector")
                self.warn(f"{self.s.path}: source {name!r} comes within {np.min(d):.1f} m of "
                          "the array (near field of the elements)")

    # -- pose ------------------------------------------------------------------------------
    def pose(self, t: np.ndarray) -> PoseTrack:
        """The array's pose at times t (s)."""
        p, _, _, crs, _ = self.own.evaluate(t)
        if self.yaw is not None:  # the heading jitter /nav does not see
            crs = crs + self.yaw(t)
        h = np.deg2rad(crs)
        idx = np.clip((t / self.s.array.lateral_snapshot).astype(np.int64), 0, self.n_snap - 1)
        lat = np.ascontiguousarray(self.lateral_offsets[idx])
        pose = PoseTrack(np.ascontiguousarray(p[:, :2]), np.ascontiguousarray(p[:, 2]),
                         np.sin(h), np.cos(h), lat)
        if self.s.array.shape == "water_pulled":
            pose.epos = np.ascontiguousarray(self.own.threaded(t, self.body, lat))
        return pose

    def element_positions(self, t: float) -> np.ndarray:
        """World positions (ch, 3) of the elements at time t (s), as the kernels build them."""
        ps = self.pose(np.array([float(t)]))
        if ps.epos.shape[0]:
            return ps.epos[0].copy()
        by = self.body[:, 1] + ps.lateral[0]
        x = ps.rpos[0, 0] + self.body[:, 0] * ps.sin_h[0] + by * ps.cos_h[0]
        y = ps.rpos[0, 1] + self.body[:, 0] * ps.cos_h[0] - by * ps.sin_h[0]
        return np.column_stack([x, y, ps.rdepth[0] + self.body[:, 2]])

    # -- rendering -------------------------------------------------------------------------
    def render(self, k0: int, k1: int) -> np.ndarray:
        """Samples [k0, k1) of every channel, float32 (n, ch), Pa."""
        n = k1 - k0
        out = np.zeros((n, self.n_channels), dtype=np.float32)
        if n <= 0:
            return out
        t = (k0 + np.arange(n)) / self.fs
        pose = self.pose(t)
        margin = self.extent / self.c
        # expansion points: exact reference retarded times on an absolute grid, interpolated
        # (the kernels solve each element's retarded time exactly from there)
        tg = grid_nodes(k0, k1, self.fs)
        ref_g = self.own.state3(tg)[0]
        mp = self.s.propagation.multipath
        ones = np.ones(n)
        for mover, sig, depth in self.sources:
            if self.bellhop is not None:
                self._render_bellhop(out, t, tg, ref_g, pose, mover, sig, depth, margin)
                continue
            paths = []  # per image path: reference retarded times, coefficient, roughness
            for img in self.images:
                im = ImageMover(mover, img)
                tau = np.interp(t, tg, retarded_time(ref_g, tg, im, self.c))
                paths.append((im, tau, img.coef, rough_exponent(mp, img, self.c)))
            tmax = max(float(p[1].max()) for p in paths)
            tmin = min(float(p[1].min()) for p in paths)
            m0 = int(np.floor((t[0] - tmax - margin) * self.fs_src)) - HALF_WIDTH - 2
            m1 = int(np.ceil((t[-1] - tmin + margin) * self.fs_src)) + HALF_WIDTH + 3
            buf = np.ascontiguousarray(sig.block(m0, m1))
            mode, r_t, gtab, g0, gdr = self.loss.kernel_args(depth, float(self.own.depth))
            for im, tau, coef, rough in paths:
                sp, sv, sa = im.state3(t - tau)
                oneway_accumulate(out, tau, sp, sv, sa, t, pose.rpos, pose.rdepth, pose.sin_h,
                                  pose.cos_h, pose.lateral, self.body, self.c, buf,
                                  m0 / self.fs_src, self.fs_src, self.table, mode, r_t, gtab,
                                  g0, gdr, coef, ones, pose.epos, rough)
        if self.active is not None:
            self.active.render(out, k0, t, pose, self.body)
        if self.noise is not None:
            out += self.noise.block(k0, k1)
        return out

    def _render_bellhop(self, out: np.ndarray, t: np.ndarray, tg: np.ndarray,
                        ref_g: np.ndarray, pose: PoseTrack, mover: object, sig: object,
                        depth: float, margin: float) -> None:
        """One source's field as the sum of its BELLHOP ray families."""
        fam = self.bellhop[float(depth)]
        paths = []
        for i in range(len(fam.tables)):
            tau = np.interp(t, tg, reference_delay(fam, i, ref_g[:, :2], tg, mover))
            paths.append((i, tau))
        tmax = max(float(p[1].max()) for p in paths)
        tmin = min(float(p[1].min()) for p in paths)
        m0 = int(np.floor((t[0] - tmax - margin) * self.fs_src)) - HALF_WIDTH - 2
        m1 = int(np.ceil((t[-1] - tmin + margin) * self.fs_src)) + HALF_WIDTH + 3
        buf, bufq = quadrature(sig.block, m0, m1, self._hilbert)
        for i, tau in paths:
            sp, sv, sa = mover.state3(t - tau)
            table_accumulate(out, tau, sp, sv, sa, t, pose.rpos, pose.rdepth, pose.sin_h,
                             pose.cos_h, pose.lateral, self.body, pose.epos, buf, bufq,
                             m0 / self.fs_src, self.fs_src, self.table, fam.tables[i],
                             fam.r0, fam.dr, 1.0)

    # -- truth -----------------------------------------------------------------------------
    def truth(self) -> tuple[dict, dict]:
        """(datasets, attrs per group) for ``/truth``."""
        s = self.s
        tt = np.arange(0.0, s.duration + 1e-9, s.truth_interval)
        groups: dict = {}
        attrs: dict = {}
        p, v, _ = self.own.state3(tt)
        groups["ownship"] = {"time": tt, "position": p[:, :2], "velocity": v[:, :2],
                             "heading": self.own.course(tt), "depth": p[:, 2]}
        src = {}
        for mover, sig, _ in self.sources:
            if not isinstance(sig, SourceSignal):
                continue
            sp = sig.spec
            p, v, _ = mover.state3(tt)
            d = {"time": tt, "position": p[:, :2], "velocity": v[:, :2]}
            a = {"depth": sp.depth, "kind": sp.kind,
                 "tonal_freqs": np.array([x.freq for x in sp.tonals], float),
                 "tonal_levels_db": np.array([x.level_db for x in sp.tonals], float),
                 "tonal_phases_deg": np.rad2deg(sig.phases)}
            if any(x.drift_hz_per_s or x.unsteady for x in sp.tonals):
                a["tonal_drift_hz_per_s"] = np.array([x.drift_hz_per_s for x in sp.tonals])
                a["tonal_coherence_time"] = np.array([
                    np.inf if x.coherence_time is None else x.coherence_time for x in sp.tonals])
                a["tonal_fading_db"] = np.array([x.fading_db for x in sp.tonals])
                a["tonal_fading_time"] = np.array([x.fading_time for x in sp.tonals])
            if sp.broadband is not None:
                bb = sp.broadband
                a["broadband_band"] = np.array(bb.band, float)
                a["broadband_model"] = bb.model
                a["broadband_slope_db_per_octave"] = bb.slope_db_per_octave
                a["broadband_level_db"] = (float(bb.level_db) if bb.model == "flat"
                                           else float("nan"))
                spec_l = sig.spectral_level_db(tt)
                d["broadband_level_db"] = spec_l
                d["broadband_source_level_db"] = spec_l + 10 * np.log10(sig.bandwidth)
            if self.s.propagation.multipath is not None:
                d.update(self._path_truth(mover, sp.depth, tt))
                a["path_surface_bounces"] = np.array([im.n_surface for im in self.images])
                a["path_bottom_bounces"] = np.array([im.n_bottom for im in self.images])
            src[sp.name] = d
            attrs[f"sources/{sp.name}"] = a
        if src:
            groups["sources"] = src
        arr = s.array
        groups["array"] = {"positions": self.body, "nominal_positions": self.nominal,
                           "lateral_time": np.arange(self.n_snap) * arr.lateral_snapshot,
                           "lateral_offset": self.lateral_offsets}
        if arr.shape == "water_pulled":  # the shape the elements took, at the truth times
            lat = self.lateral_offsets[np.clip((tt / arr.lateral_snapshot).astype(np.int64),
                                               0, self.n_snap - 1)]
            groups["array"]["shape_time"] = tt
            groups["array"]["element_positions"] = self.own.threaded(tt, self.body, lat)
        attrs["array"] = {"shape": arr.shape, "position_error_std": arr.position_error_std,
                          "lateral_std": arr.lateral_std,
                          "lateral_snapshot": arr.lateral_snapshot, "depth": arr.depth}
        if self.yaw is not None:  # written only with a jitter: the other files are unchanged
            groups["array"]["yaw_time"] = self.yaw.time
            groups["array"]["yaw_deg"] = self.yaw.values
            attrs["array"].update(yaw_std=arr.yaw_std, yaw_time=arr.yaw_time)
        if self.active is not None:
            act, act_attrs = self.active.truth()
            groups.update(act)
            attrs["pings"] = act_attrs
        return groups, attrs

    def _path_truth(self, mover: object, depth: float, tt: np.ndarray) -> dict:
        """Per image path at the array reference point: travel time (s) and signed amplitude
        gain (reflections × roughness / path length, 1/m), columns in image order."""
        ref = self.own.state3(tt)[0]
        delay, amp = [], []
        for img in self.images:
            tau = retarded_time(ref, tt, ImageMover(mover, img), self.c)
            sin_g = path_sin_grazing(img.depth(depth), ref[:, 2], self.c * tau)
            rough = roughness_factor(self.s.propagation.multipath, img, sin_g, self.c)
            delay.append(tau)
            amp.append(img.coef * rough / np.maximum(self.c * tau, 1.0))
        return {"path_delay_s": np.column_stack(delay), "path_amplitude": np.column_stack(amp)}

    def nav(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(time, position (n, 2), heading deg, depth) of the array reference point."""
        s = self.s
        tn = np.arange(0.0, s.duration, s.nav_interval)
        tn = np.append(tn, s.duration) if tn[-1] < s.duration else tn
        p, _, _ = self.own.state3(tn)
        return tn, p[:, :2], self.own.course(tn), p[:, 2]


def _write_truth(w: RecordingWriter, groups: dict, attrs: dict) -> None:
    def walk(prefix: str, d: dict) -> None:
        data = {k: v for k, v in d.items() if not isinstance(v, dict)}
        w.write_group(prefix, data, attrs.get(prefix[len("truth/"):], None))
        for k, v in d.items():
            if isinstance(v, dict):
                walk(f"{prefix}/{k}", v)
    walk("truth", groups)


def simulate(scen: Scenario, out_path: str | Path,
             progress: Callable[[float, float], None] | None = None,
             warn: Callable[[str], None] | None = None) -> Path:
    """Simulate a validated scenario into a recording file (atomic write); ``progress``, when
    given, is called as ``progress(done_s, total_s)`` in seconds of audio after each chunk."""
    sim = Simulator(scen, warn)
    n = sim.n_samples
    attrs = {"simulator": "arrayproc.sim", "scenario": Path(scen.path).name,
             "seed": scen.seed}
    with RecordingWriter(out_path, scen.fs, sim.n_channels, positions=sim.nominal,
                         sound_speed=scen.sound_speed, start_time=scen.start_time,
                         attrs=attrs, expected_samples=n) as w:
        for k0 in range(0, n, scen.chunk):
            k1 = min(n, k0 + scen.chunk)
            w.append(sim.render(k0, k1))
            if progress:
                progress(k1 / scen.fs, n / scen.fs)
        w.set_nav(*sim.nav())
        if sim.active is not None:
            w.set_active(*sim.active.recording_active())
        groups, gattrs = sim.truth()
        _write_truth(w, groups, gattrs)
    return Path(out_path)


def simulate_file(scenario_path: str | Path, out_path: str | Path, seed: int | None = None,
                  duration: float | None = None,
                  progress: Callable[[float, float], None] | None = None,
                  warn: Callable[[str], None] | None = None) -> Path:
    """``arrayproc simulate``: read and validate the scenario, then stream the recording.

    Parameters
    ----------
    scenario_path : str or Path
        Scenario TOML (docs/formats.md).
    out_path : str or Path
        Recording to write (atomically: nothing is left if the run fails).
    seed : int, optional
        Overrides ``[recording] seed``; the same seed gives the same bytes.
    duration : float, optional
        Overrides the scenario's duration, s (to shorten it for a quick look).
    progress : callable, optional
        Called as ``progress(done_s, total_s)`` in seconds of audio after each chunk.
    warn : callable, optional
        Receives warnings as one line each.

    Returns
    -------
    Path
        The recording written.
    """
    scen = load_scenario(scenario_path)
    if seed is not None:
        if seed < 0:
            raise ConfigError(f"--seed must be >= 0, got {seed}")
        scen.seed = int(seed)
    if duration is not None:
        if not duration > 0:
            raise ConfigError(f"--duration must be > 0, got {duration}")
        if duration > scen.duration and warn is not None:
            warn(f"--duration {duration:g} s is longer than the scenario's {scen.duration:g} s")
        scen.duration = float(duration)
    return simulate(scen, out_path, progress=progress, warn=warn)
