"""Scenario files (TOML) → validated, typed scenario objects (format in docs/formats.md).

Every key is declared once in :mod:`arrayproc.sim.scenario_keys`; each table is read through
its schema (:class:`~arrayproc.config.Section`), and the rules across keys are checked here.
Every user mistake (unknown key, wrong type, missing key, impossible value) raises one
:class:`ConfigError` naming the file and the key, before anything is written.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Any

import numpy as np

from arrayproc.config import Section, read_toml
from arrayproc.dsp.fracdelay import PASSBAND
from arrayproc.errors import ConfigError
from arrayproc.geo.kinematics import KNOT, Trajectory
from arrayproc.io.geometry import line_array, triplet_array, twin_line_array
from arrayproc.sim.scenario_keys import MAX_LEVEL_DB, SCENARIO, WAVEFORM
from arrayproc.sim.unsteady import NODE

__all__ = ["load_scenario", "parse_scenario", "tetrahedron", "MAX_LEVEL_DB"]


def _speed(t: Section, required: bool = True) -> float | None:
    """``speed`` (m/s) or ``speed_kn`` (knots)."""
    if t.has("speed") and t.has("speed_kn"):
        raise t.err("speed", "give speed (m/s) or speed_kn (knots), not both")
    if t.has("speed_kn"):
        return t["speed_kn"] * KNOT
    if t.has("speed"):
        return t["speed"]
    if required:
        raise t.err("speed", "missing (a number is required)")
    return 0.0


def _legs(t: Section) -> list[dict[str, Any]]:
    """The ``[[leg]]`` tables as :meth:`Trajectory.from_legs` reads them."""
    legs = []
    for lt in t.subs("leg"):
        leg = {"course": lt["course"], "speed": _speed(lt), "duration": lt["duration"]}
        if lt.has("turn_rate"):
            leg["turn_rate"] = lt["turn_rate"]
        if lt.has("turn"):
            leg["turn"] = lt["turn"]
        legs.append(leg)
    return legs


def _trajectory(t: Section) -> tuple[Trajectory, bool]:
    """``start`` [x, y] and either ``course``+``speed``/``speed_kn`` or ``[[leg]]``s, or
    ``heading`` (static). Returns (trajectory, static)."""
    start = np.asarray(t["start"], float)
    moving = t.has("course") or t.has("speed") or t.has("speed_kn")
    if t.has("heading") and (t.has("leg") or moving):
        raise t.err("heading", "only for a static track (the heading of a moving one is its "
                    "course); give heading or course/speed/legs, not both")
    if t.has("leg"):
        if moving:
            raise t.err("leg", "give legs or course/speed, not both")
        try:
            return Trajectory.from_legs(start, _legs(t)), False
        except ConfigError as e:
            raise ConfigError(f"{t.file}: [{t.where}]: {e}") from None
    if moving:
        course = t.need("course", "a number is required")
        speed = _speed(t)
        # one open-ended leg (held after its end by Trajectory)
        traj = Trajectory.from_legs(start, [{"course": course, "speed": speed, "duration": 0.0}])
        return traj, speed == 0.0
    return Trajectory.static(start, t["heading"] or 0.0), True


# -- scenario objects ----------------------------------------------------------------------
@dataclass
class Tonal:
    freq: float  # Hz
    level_db: float  # dB re 1 µPa @ 1 m (RMS)
    phase_deg: float | None = None  # None: random (seeded)
    drift_hz_per_s: float = 0.0  # linear frequency drift, f(t) = freq + drift·t
    coherence_time: float | None = None  # s, random-walk phase (None: coherent)
    fading_db: float = 0.0  # std of the log-amplitude fade, dB (0: steady)
    fading_time: float = 10.0  # s, correlation time of the fade

    @property
    def unsteady(self) -> bool:
        return self.coherence_time is not None or self.fading_db > 0


@dataclass
class Broadband:
    band: tuple[float, float]  # Hz
    level_db: float | None  # spectral, dB re 1 µPa²/Hz @ 1 m (None with model="speed")
    model: str = "flat"  # "flat" | "speed" (SPL paper eq. (12))
    slope_db_per_octave: float = 0.0  # colour within the band, relative to the band's low edge


@dataclass
class SourceSpec:
    name: str
    traj: Trajectory
    depth: float
    tonals: list[Tonal] = field(default_factory=list)
    broadband: Broadband | None = None
    lead: float = 0.0  # s (tow ship: position of the ownship track this much later)
    kind: str = "source"  # "source" | "towship"


@dataclass
class ArraySpec:
    positions: np.ndarray  # (n, 3) nominal, body frame
    depth: float
    position_error_std: float = 0.0
    lateral_std: float = 0.0
    lateral_snapshot: float = 1.0
    shape: str = "rigid"  # "rigid" | "water_pulled" (elements thread the tow point's path)
    yaw_std: float = 0.0  # deg, Gauss-Markov heading jitter (arrayproc.sim.yaw)
    yaw_time: float = 20.0  # s, its correlation time


@dataclass
class MultipathSpec:
    """``[propagation] multipath``: image sources in a flat waveguide (arrayproc.sim.multipath).

    ``bottom_depth`` None: no bottom (surface image only); ``surface`` False: no surface
    reflection (bottom image only). ``order``: most reflections on a path. The rough surface's
    coherent reflection uses the Rayleigh parameter Γ = 2kσ sin θ at ``roughness_freq``.
    """

    surface: bool = True
    bottom_depth: float | None = None  # m
    bottom_loss_db: float = 0.0  # dB per bottom bounce
    order: int = 1
    surface_rms_height: float = 0.0  # m (σ)
    roughness_freq: float = 0.0  # Hz (k = 2π f / c of the Rayleigh parameter)


@dataclass
class BellhopSpec:
    """``multipath = "bellhop"`` with ``[propagation.bellhop]``: a range-independent
    environment whose BELLHOP arrivals are the propagation paths."""

    depth: float | None = None  # m, flat bottom; None: the TL tables' Munk environment
    freq: float | None = None  # Hz of the ray trace; None: the loudest tonal's (or band centre)
    max_range: float | None = None  # m; None: from the scenario's geometry
    range_step: float = 10.0  # m
    ssp: np.ndarray | None = None  # (n, 2) depth m, speed m/s; None: isovelocity
    bottom_speed: float = 1600.0
    bottom_density: float = 1.8  # g/cm³
    bottom_atten: float = 0.5  # dB/λ (0.8 in the Munk environment)
    n_beams: int = 0  # 0: BELLHOP chooses


@dataclass
class Propagation:
    loss: str = "spherical"  # spherical | cylindrical | table
    transition_range: float = 1.0
    table_range: np.ndarray | None = None  # m
    table_tl: np.ndarray | None = None  # dB, or a TLTable object resolved per depth pair
    table_path: str | None = None
    multipath: MultipathSpec | None = None
    bellhop: BellhopSpec | None = None


@dataclass
class NoiseSpec:
    level_db: float | None = None  # dB re 1 µPa²/Hz
    spectrum: np.ndarray | None = None  # (n, 2): freq Hz, level dB


@dataclass
class TargetSpec:
    name: str
    traj: Trajectory | None
    depth: float
    ts_db: float
    distortion: float = 0.0  # s, thesis eq. (4.6) α
    source: str | None = None  # reuse a passive source's track
    length: float = 0.0  # m: an extended target, highlights spread along its course
    highlights: int = 1  # point scatterers along the length, TS split evenly


@dataclass
class ReverbSpec:
    """Boundary reverberation: random Lambert scatterers on the bottom or the surface."""

    boundary: str  # "bottom" | "surface"
    depth: float  # m, the boundary's depth (0 for the surface)
    strength_db: float  # Lambert parameter 10 log10 μ, dB (S = 10 log10 μ + 10 log10 sin θi sin θs)
    density: float  # scatterers per m²
    area: np.ndarray  # [xmin, xmax, ymin, ymax] m


@dataclass
class FeatureSpec:
    """A bottom feature (ridge, wreck): static point scatterers at chosen positions."""

    name: str
    points: np.ndarray  # (n, 2) x, y m
    depth: float
    ts_db: float  # per point


@dataclass
class ClutterSpec:
    count: int
    area: np.ndarray  # [xmin, xmax, ymin, ymax] m
    depth: float
    ts_mean_db: float
    ts_std_db: float
    drift_speed_std: float = 0.0  # m/s per horizontal axis (0: static points)


@dataclass
class ActiveSpec:
    """The ``[active]`` section: named waveforms, the ping schedule, targets and clutter.

    Ping k is transmitted at ``times[k]`` when explicit times are given, else at
    ``first + k·interval``; its waveform is ``schedule[k mod len(schedule)]``. The
    single-waveform form (``waveform = "bpsk"`` …) is one waveform named after its kind.
    """

    waveforms: dict[str, Any]  # name -> arrayproc.acoustics.waveforms.Waveform
    levels: dict[str, float]  # name -> source level, dB re 1 µPa @ 1 m
    schedule: list[str]  # waveform names, cycled over the pings
    level_db: float
    interval: float | None
    first: float
    count: int | None
    offset: np.ndarray
    direct: bool
    targets: list[TargetSpec]
    clutter: ClutterSpec | None
    times: np.ndarray | None = None  # explicit transmission times, s
    reverberation: list[ReverbSpec] = field(default_factory=list)
    features: list[FeatureSpec] = field(default_factory=list)

    @property
    def waveform(self) -> Any:
        """The first scheduled waveform (the only one in the single-waveform form)."""
        return self.waveforms[self.schedule[0]]

    def pings(self, duration: float) -> tuple[np.ndarray, list[str]]:
        """Transmission times (s) inside [0, ``duration``) and each ping's waveform name.

        Parameters
        ----------
        duration : float
            Recording length, s.

        Returns
        -------
        times : (n,) ndarray
            Increasing transmission start times, s.
        names : list of str
            Waveform name of each ping.
        """
        if self.times is not None:
            t = np.asarray(self.times, float)
        else:
            n = self.count if self.count is not None else int(
                np.floor((duration - self.first) / self.interval)) + 1
            t = self.first + self.interval * np.arange(max(n, 0))
        t = t[t < duration]
        return t, [self.schedule[k % len(self.schedule)] for k in range(t.size)]


@dataclass
class Scenario:
    path: str
    fs: float
    duration: float
    sound_speed: float
    seed: int
    start_time: str | None
    chunk: int
    truth_interval: float
    nav_interval: float
    array: ArraySpec
    ownship: Trajectory
    ownship_static: bool
    sources: list[SourceSpec]
    propagation: Propagation
    noise: NoiseSpec | None
    active: ActiveSpec | None


def tetrahedron(side: float) -> np.ndarray:
    """Regular tetrahedron (4, 3) with edge ``side`` (m), centroid at the origin: a horizontal
    base triangle (one vertex forward) and the apex above it (z down, so apex z < 0)."""
    rb = side / math.sqrt(3.0)
    h = side * math.sqrt(2.0 / 3.0)
    ang = np.deg2rad([0.0, 120.0, 240.0])
    base = np.stack([rb * np.cos(ang), rb * np.sin(ang), np.full(3, h / 4)], axis=1)
    return np.vstack([base, [[0.0, 0.0, -0.75 * h]]])


def _only(t: Section, keys: tuple[str, ...], when: str) -> None:
    """Refuse any of ``keys`` given where they do not apply (``when`` says where they do)."""
    for k in keys:
        if t.has(k):
            raise t.err(k, f"only {when}")


def _check_speed(t: Section, traj: Trajectory, c: float) -> None:
    """A platform moves slower than sound (the simulator's retarded-time solver needs it)."""
    fastest = max((seg.speed for seg in traj.segments), default=0.0)
    if fastest >= c:
        raise t.err("speed", f"{fastest:g} m/s is not below the sound speed {c:g} m/s")


def _tonals(t: Section, fs: float) -> list[Tonal]:
    out = []
    node = NODE / (2.0 * fs)  # the processes' grid spacing (source rate 2·fs)
    for tt in t.subs("tonals"):
        f = tt["freq"]
        if f > PASSBAND * fs:
            raise tt.err("freq", f"{f} Hz is above the simulator's band "
                         f"({PASSBAND:g}·fs = {PASSBAND * fs:g} Hz)")
        ton = Tonal(f, tt["level_db"], tt["phase_deg"], tt["drift_hz_per_s"],
                    tt["coherence_time"], tt["fading_db"], tt["fading_time"])
        for key, v in (("coherence_time", ton.coherence_time), ("fading_time",
                                                                  ton.fading_time)):
            if v is not None and v < 50 * node and (key == "coherence_time" or ton.fading_db):
                raise tt.err(key, f"{v:g} s is too short for the simulator's grid of "
                             f"{node * 1e3:.2f} ms (at least {50 * node:.3g} s)")
        out.append(ton)
    return out


def _broadband(t: Section | None, fs: float) -> Broadband | None:
    if t is None:
        return None
    band = t["band"]
    if not (0 <= band[0] < band[1]):
        raise t.err("band", f"must be [lo, hi] with 0 <= lo < hi, got {band}")
    if band[1] > PASSBAND * fs:
        raise t.err("band", f"upper edge {band[1]} Hz is above the simulator's band "
                    f"({PASSBAND:g}·fs = {PASSBAND * fs:g} Hz)")
    model, level = t["model"], t["level_db"]
    if model == "flat" and level is None:
        raise t.err("level_db", "missing (a number is required)")
    if model == "speed" and level is not None:
        raise t.err("level_db", "not used with model = \"speed\" (the level follows the speed)")
    return Broadband((float(band[0]), float(band[1])), level, model, t["slope_db_per_octave"])


def _multipath(pt: Section, loss: str) -> MultipathSpec:
    """The ``multipath = { … }`` inline table of ``[propagation]``."""
    if not isinstance(pt["multipath"], dict):
        raise pt.err("multipath", "must be a table {surface, bottom_depth, bottom_loss_db, "
                     f"order, …}} or \"bellhop\", got {pt['multipath']!r}")
    if loss != "spherical":
        raise pt.err("multipath", f"image sources need loss = \"spherical\" (a {loss} law "
                     "already stands for the boundaries' contribution)")
    mt = pt.sub("multipath")
    spec = MultipathSpec(mt["surface"], mt["bottom_depth"], mt["bottom_loss_db"], mt["order"],
                         mt["surface_rms_height"], mt["roughness_freq"])
    if spec.surface_rms_height > 0 and spec.roughness_freq <= 0:
        raise mt.err("roughness_freq", "required (> 0 Hz) with surface_rms_height > 0: the "
                     "Rayleigh parameter 2kσ sin θ is evaluated at this frequency")
    if spec.surface_rms_height > 0 and not spec.surface:
        raise mt.err("surface_rms_height", "needs surface = true")
    return spec


def _bellhop(pt: Section, loss: str, c: float) -> BellhopSpec:
    """``multipath = "bellhop"`` and its ``[propagation.bellhop]`` environment."""
    if loss != "spherical":
        raise pt.err("multipath", f"BELLHOP arrivals replace the loss law; leave loss = "
                     f"\"spherical\" (got {loss!r})")
    bt = pt.sub("bellhop") or Section({}, pt.schema["bellhop"].schema, "propagation.bellhop",
                                      pt.file)
    ssp = None if bt["ssp"] is None else np.asarray(bt["ssp"], float)
    munk = not bt.has("depth")
    if munk and ssp is not None:
        raise bt.err("ssp", "give the bottom depth too")
    atten = bt["bottom_atten"] if bt.has("bottom_atten") else (0.8 if munk else 0.5)
    spec = BellhopSpec(bt["depth"], bt["freq"], bt["max_range"], bt["range_step"], ssp,
                       bt["bottom_speed"], bt["bottom_density"], atten, bt["n_beams"])
    if munk:  # the environment of the bundled TL tables (SPL paper appendix)
        from arrayproc.acoustics.tl.bellhop import MUNK_APPENDIX
        spec.depth, spec.ssp = float(MUNK_APPENDIX[-1, 0]), MUNK_APPENDIX.copy()
    if ssp is not None and (np.any(np.diff(ssp[:, 0]) <= 0) or ssp[0, 0] != 0.0
                            or ssp[-1, 0] != spec.depth):
        raise bt.err("ssp", "depths must increase from 0 to the bottom depth")
    if spec.max_range is not None and spec.max_range / spec.range_step > 20000:
        raise bt.err("range_step", "more than 20000 ranges; use a coarser step")
    return spec


def _bellhop_freq(sources: list[SourceSpec], active: ActiveSpec | None = None) -> float:
    """Frequency of the ray trace when not given: the loudest tonal's, else the centre of the
    first broadband band, else the centre of the first scheduled ping waveform's band."""
    tonals = [t for sp in sources for t in sp.tonals]
    if tonals:
        return float(max(tonals, key=lambda t: t.level_db).freq)
    bands = [sp.broadband.band for sp in sources if sp.broadband is not None]
    if not bands and active is not None:
        bands = [active.waveforms[active.schedule[0]].band]
    return float(0.5 * (bands[0][0] + bands[0][1])) if bands else 50.0


def _check_waveguide(mp: MultipathSpec, array: ArraySpec, sources: list[SourceSpec],
                     active: ActiveSpec | None, file: str) -> None:
    """Every source, element, target and the projector lie in the water, 0 <= z <= D."""
    d = mp.bottom_depth if mp.bottom_depth is not None else math.inf
    where = [("[array] depth (elements)", array.depth + array.positions[:, 2])]
    where += [(f"source {sp.name!r} depth", np.array([sp.depth])) for sp in sources]
    if active is not None:
        where += [(f"target {tg.name!r} depth", np.array([tg.depth])) for tg in active.targets]
        where.append(("[active] offset (projector depth)",
                      np.array([array.depth + active.offset[2]])))
        if active.clutter is not None:
            where.append(("[active.clutter] depth", np.array([active.clutter.depth])))
        where += [("[active.reverberation] depth", np.array([r.depth]))
                  for r in active.reverberation]
        where += [(f"feature {f.name!r} depth", np.array([f.depth])) for f in active.features]
    for what, z in where:
        if np.any(z < 0) or np.any(z > d):
            raise ConfigError(f"{file}: [propagation] multipath: {what} "
                              f"{float(z.min()):g}…{float(z.max()):g} m is outside the water "
                              f"(0 … {d:g} m)")


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario TOML file."""
    p = Path(path)
    data, _ = read_toml(p, "scenario")
    return parse_scenario(data, str(p), base_dir=p.parent)


def parse_scenario(data: dict, file: str = "<scenario>",
                   base_dir: Path | None = None) -> Scenario:
    """Validate a scenario given as a dict (as loaded from TOML): the tables in file order,
    then the checks across tables (waveguide, BELLHOP, tonal drift)."""
    root = Section(data, SCENARIO, "", file)
    fs, duration, c, seed, start_time, chunk, truth_interval, nav_interval = _recording(root)
    array, at = _array(root)
    own, own_static = _ownship(root, c)
    if array.shape == "water_pulled" and min(
            [sg.speed for sg in own.segments] or [0.0]) <= 0:
        raise at.err("shape", "water_pulled needs an ownship moving at speed > 0 on every "
                     "leg (the elements follow the path the tow point took)")
    sources = _sources(root, fs, c, file)
    prop = _propagation(root, c, base_dir)
    noise = _noise(root, fs, own, sources, file)
    active = _active(root.sub("active"), fs, sources, file) if root.has("active") else None
    if prop.multipath is not None:
        _check_waveguide(prop.multipath, array, sources, active, file)
    if prop.bellhop is not None:
        _check_waveguide(MultipathSpec(bottom_depth=prop.bellhop.depth), array, sources,
                         active, file)
        if prop.bellhop.freq is None:
            prop.bellhop.freq = _bellhop_freq(sources, active)
    _check_drift(sources, duration, fs, file)
    return Scenario(file, fs, duration, c, seed, start_time, chunk, truth_interval,
                    nav_interval, array, own, own_static, sources, prop, noise, active)


def _recording(root: Section) -> tuple:
    """``[recording]``: (fs, duration, sound speed, seed, start time, chunk, truth and nav
    intervals)."""
    rec = root.sub("recording", required=True)
    start_time = rec["start_time"]
    if start_time is not None:
        try:
            datetime.fromisoformat(start_time.replace("Z", "+00:00"))
        except ValueError:
            raise rec.err("start_time", f"not an ISO-8601 time: {start_time!r}") from None
    return (rec["fs"], rec["duration"], rec["sound_speed"], rec["seed"], start_time,
            rec["chunk"], rec["truth_interval"], rec["nav_interval"])


#: The layout keys each array type reads (the others are refused for it).
_LAYOUT_KEYS = {"line": ("n", "spacing"), "twin": ("n", "spacing", "separation"),
                "triplet": ("n", "spacing", "radius"), "tetrahedron": ("side",),
                "positions": ("positions",)}


def _array(root: Section) -> tuple[ArraySpec, Section]:
    """``[array]``: the element layout of its ``type`` and the error and shape keys; the
    spec and the table (for messages about it)."""
    at = root.sub("array", required=True)
    kind = at["type"]
    used = _LAYOUT_KEYS[kind]
    for k in ("n", "spacing", "separation", "radius", "side", "positions"):
        if at.has(k) and k not in used:
            types = [t for t, ks in _LAYOUT_KEYS.items() if k in ks]
            raise at.err(k, f"not used by type = {kind!r} (only {' / '.join(types)})")
    need = {k: at.need(k, "required by type = " + repr(kind)) for k in used}
    if kind == "twin":
        pos = twin_line_array(need["n"], need["spacing"], need["separation"])
    elif kind == "triplet":
        pos = triplet_array(need["n"], need["spacing"], need["radius"])
    elif kind == "line":
        pos = line_array(need["n"], need["spacing"])
    elif kind == "tetrahedron":
        pos = tetrahedron(need["side"])
    else:
        pos = np.asarray(need["positions"], float)
    if at["yaw_std"] > 0 and at["shape"] == "water_pulled":
        raise at.err("yaw_std", "a heading jitter needs a rigid array (shape = 'rigid')")
    array = ArraySpec(pos, at["depth"], at["position_error_std"], at["lateral_std"],
                      at["lateral_snapshot"], at["shape"], at["yaw_std"], at["yaw_time"])
    return array, at


def _ownship(root: Section, c: float) -> tuple[Trajectory, bool]:
    """``[ownship]``: its trajectory and whether it is static (no table: at the origin)."""
    ot = root.sub("ownship")
    if ot is None:
        return Trajectory.static((0.0, 0.0), 0.0), True
    own, own_static = _trajectory(ot)
    _check_speed(ot, own, c)
    return own, own_static


def _plain_name(t: Section, key: str, name: str, what: str) -> None:
    if not name or "/" in name or name in (".", ".."):
        raise t.err(key, f"{name!r} must be a plain name (not empty, no '/', not '.' or "
                    f"'..'): it names {what}")


def _sources(root: Section, fs: float, c: float, file: str) -> list[SourceSpec]:
    """The ``[[source]]`` tables: unique plain names, a trajectory, tonals or broadband."""
    sources: list[SourceSpec] = []
    names: set[str] = set()
    for i, st in enumerate(root.subs("source")):
        name = st["name"] if st["name"] is not None else f"source{i}"
        if name in names or name in ("ownship", "towship"):
            raise st.err("name", f"duplicate or reserved source name {name!r}")
        _plain_name(st, "name", name, "the source's /truth group")
        names.add(name)
        traj, _ = _trajectory(st)
        _check_speed(st, traj, c)
        tonals = _tonals(st, fs)
        bb = _broadband(st.sub("broadband"), fs)
        if not tonals and bb is None:
            raise ConfigError(f"{file}: [{st.where}]: a source needs tonals or [broadband]")
        sources.append(SourceSpec(name, traj, st["depth"], tonals, bb))
    return sources


def _propagation(root: Section, c: float, base_dir: Path | None) -> Propagation:
    """``[propagation]``: the loss law (a TL table from a file or inline), multipath."""
    prop = Propagation()
    pt = root.sub("propagation")
    if pt is None:
        return prop
    prop.loss, prop.transition_range = pt["loss"], pt["transition_range"]
    if prop.loss != "table":
        _only(pt, ("file", "range_m", "tl_db"), "with loss = \"table\"")
    elif pt.has("file"):
        f = Path(pt["file"])
        if not f.is_absolute() and base_dir is not None:
            f = base_dir / f
        if not f.exists():
            raise pt.err("file", f"no such TL table {str(f)!r}")
        _only(pt, ("range_m", "tl_db"), "without file (an inline table)")
        prop.table_path = str(f)
    else:
        r = np.asarray(pt.need("range_m", "a list of numbers is required"), float)
        tl = np.asarray(pt.need("tl_db", "a list of numbers is required"), float)
        if r.size != tl.size or r.size < 2 or np.any(np.diff(r) <= 0):
            raise pt.err("range_m", "range_m and tl_db must have the same length >= 2 "
                         "and range_m must increase")
        prop.table_range, prop.table_tl = r, tl
    if pt.has("multipath") and pt["multipath"] == "bellhop":
        prop.bellhop = _bellhop(pt, prop.loss, c)
    elif pt.has("multipath"):
        prop.multipath = _multipath(pt, prop.loss)
    if pt.has("bellhop") and prop.bellhop is None:
        raise pt.err("bellhop", "only with multipath = \"bellhop\"")
    return prop


def _noise(root: Section, fs: float, own: Trajectory, sources: list[SourceSpec],
           file: str) -> NoiseSpec | None:
    """``[noise]``: a flat level or a spectrum; its ``[noise.towship]`` is appended to
    ``sources`` as a source following the ownship's path ``distance`` m ahead."""
    nt = root.sub("noise")
    if nt is None:
        return None
    noise = None
    lvl = nt["level_db"]
    spec = None if nt["spectrum"] is None else np.asarray(nt["spectrum"], float)
    if lvl is not None and spec is not None:
        raise nt.err("spectrum", "give level_db (flat) or spectrum, not both")
    if spec is not None and (np.any(spec[:, 0] <= 0) or np.any(np.diff(spec[:, 0]) <= 0)):
        raise nt.err("spectrum", "frequencies must be > 0 and increasing")
    if lvl is not None or spec is not None:
        noise = NoiseSpec(lvl, spec)
    tt = nt.sub("towship")
    if tt is not None:
        tonals = _tonals(tt, fs)
        bb = _broadband(tt.sub("broadband"), fs)
        if not tonals and bb is None:
            raise ConfigError(f"{file}: [{tt.where}]: the tow ship needs tonals or "
                              "[broadband]")
        sources.append(SourceSpec("towship", own, tt["depth"], tonals, bb,
                                  lead=tt["distance"], kind="towship"))
    return noise


def _check_drift(sources: list[SourceSpec], duration: float, fs: float, file: str) -> None:
    """Every drifting tonal stays inside (0, passband] Hz to the end of the recording."""
    for sp in sources:
        for i, ton in enumerate(sp.tonals):
            f_end = ton.freq + ton.drift_hz_per_s * duration
            if ton.drift_hz_per_s and not (0 < f_end <= PASSBAND * fs):
                raise ConfigError(f"{file}: source {sp.name!r} tonal {i}: drift_hz_per_s takes "
                                  f"the tonal to {f_end:g} Hz by the end, outside (0, "
                                  f"{PASSBAND * fs:g}] Hz")


#: The waveform keys each kind reads.
_WAVE_KEYS = {"bpsk": ("fc", "bits"), "hfm": ("f0", "f1"), "cw": ("fc",)}


def _waveform(t: Section, fs: float, file: str) -> Any:
    """One waveform from ``waveform`` (kind), ``duration``, ``taper`` and the kind's keys."""
    from arrayproc.acoustics import waveforms as wf

    kind = t.need("waveform", "a string is required")
    dur = t.need("duration", "a number is required")
    _only(t, tuple(k for k in ("fc", "bits", "f0", "f1") if k not in _WAVE_KEYS[kind]),
          f"with another waveform (not {kind})")
    need = {k: t.need(k, "a number is required") for k in _WAVE_KEYS[kind]}
    try:
        if kind == "bpsk":
            w = wf.bpsk(need["fc"], dur, need["bits"], t["taper"])
        elif kind == "hfm":
            w = wf.hfm(need["f0"], need["f1"], dur, t["taper"])
        else:
            w = wf.cw(need["fc"], dur, t["taper"])
    except ValueError as e:
        raise ConfigError(f"{file}: [{t.where}]: {e}") from None
    if w.band[1] > PASSBAND * fs:
        raise t.err("waveform", f"band up to {w.band[1]:g} Hz is above the simulator's band "
                    f"({PASSBAND:g}·fs = {PASSBAND * fs:g} Hz)")
    return w


def _named_waveforms(t: Section, fs: float, file: str, level: float
                     ) -> tuple[dict[str, Any], dict[str, float], list[str]]:
    """``[active.waveforms.<name>]`` tables and ``schedule = [names…]``."""
    for k in ("waveform", "duration", "taper", "fc", "bits", "f0", "f1"):
        if t.has(k):
            raise t.err(k, "give the waveform in [active] (one waveform) or in "
                        "[active.waveforms.<name>] tables, not both")
    raw = t["waveforms"]
    if not raw:
        raise t.err("waveforms", "must hold one or more [active.waveforms.<name>] tables")
    waves, levels = {}, {}
    for name, sub in raw.items():
        _plain_name(t, "waveforms", name, "the replica /active/waveforms/<name>")
        wt = Section(sub, WAVEFORM, f"{t.where}.waveforms.{name}", file)
        waves[name] = _waveform(wt, fs, file)
        levels[name] = wt["level_db"] if wt["level_db"] is not None else level
    if t.has("schedule"):
        sched = t["schedule"]
        if (not isinstance(sched, list) or not sched
                or not all(isinstance(x, str) for x in sched)):
            raise t.err("schedule", f"must be a non-empty list of waveform names, got "
                        f"{sched!r}")
        bad = [x for x in sched if x not in waves]
        if bad:
            raise t.err("schedule", f"{bad[0]!r} is not a waveform (declared: "
                        f"{', '.join(sorted(waves))})")
    elif len(waves) == 1:
        sched = list(waves)
    else:
        raise t.err("schedule", "missing: list the waveform names in transmission order, "
                    f"e.g. schedule = {sorted(waves)!r}")
    return waves, levels, list(sched)


def _schedule(t: Section, fs: float, file: str, level: float
              ) -> tuple[dict[str, Any], dict[str, float], list[str], np.ndarray | None]:
    """Waveforms, their levels, the schedule and explicit times of the ``[active]`` table.

    Single-waveform form: ``waveform = "<kind>"`` and its keys in ``[active]`` (the replica is
    named after the kind). Several waveforms: ``[active.waveforms.<name>]`` tables with the
    same keys (plus an optional ``level_db``) and ``schedule = [names…]`` cycled over the pings.
    """
    if t.has("waveforms"):
        waves, levels, sched = _named_waveforms(t, fs, file, level)
    else:
        if t.has("schedule"):
            raise t.err("schedule", "needs [active.waveforms.<name>] tables (the single "
                        "waveform of [active] is every ping's)")
        w = _waveform(t, fs, file)
        waves, levels, sched = {w.kind: w}, {w.kind: level}, [w.kind]
    times = None
    if t.has("times"):
        for k in ("interval", "first", "count"):
            if t.has(k):
                raise t.err(k, "not used with explicit times (give times or "
                            "interval/first/count, not both)")
        times = np.asarray(t["times"], float)
        if times.size == 0 or np.any(times < 0) or np.any(np.diff(times) <= 0):
            raise t.err("times", "must be a non-empty increasing list of times >= 0 s")
    return waves, levels, sched, times


def _check_overlap(t: Section, spec: ActiveSpec) -> None:
    """A ping ends before the next one starts (several waveforms or explicit times)."""
    if spec.times is not None:
        t_next = np.diff(spec.times)
        k = np.arange(t_next.size)
    else:
        t_next = np.full(len(spec.schedule), spec.interval)
        k = np.arange(t_next.size)
    dur = np.array([spec.waveforms[spec.schedule[i % len(spec.schedule)]].duration for i in k])
    bad = np.flatnonzero(t_next < dur)
    if bad.size:
        i = int(bad[0])
        key = "times" if spec.times is not None else "interval"
        raise t.err(key, f"ping {i} ({spec.schedule[i % len(spec.schedule)]}, "
                    f"{dur[i]:g} s) lasts past the next ping ({t_next[i]:g} s later)")


#: Most reverberation scatterers one scenario may ask for (each is rendered per ping).
MAX_REVERB_SCATTERERS = 200_000


def _area(t: Section) -> np.ndarray:
    """``area = [xmin, xmax, ymin, ymax]`` with min < max."""
    area = np.asarray(t["area"], float)
    if not (area[0] < area[1] and area[2] < area[3]):
        raise t.err("area", "must be [xmin, xmax, ymin, ymax] with min < max")
    return area


def _reverb(t: Section) -> ReverbSpec:
    """One ``[[active.reverberation]]`` table."""
    boundary = t["boundary"]
    if boundary == "bottom":
        depth = t.need("depth", "a number is required")
        if depth <= 0:
            raise t.err("depth", f"must be > 0, got {depth}")
    else:
        depth = t["depth"] if t["depth"] is not None else 0.0
        if depth != 0.0:
            raise t.err("depth", "the surface is at depth 0")
    area = _area(t)
    spec = ReverbSpec(boundary, depth, t["scattering_strength_db"], t["density"], area)
    n = spec.density * (area[1] - area[0]) * (area[3] - area[2])
    if n > MAX_REVERB_SCATTERERS:
        raise t.err("density", f"{n:.0f} scatterers over the area (at most "
                    f"{MAX_REVERB_SCATTERERS}); lower the density or the area")
    return spec


def _feature(t: Section, i: int) -> FeatureSpec:
    """One ``[[active.feature]]``: ``position = [x, y]`` (a wreck) or ``line = [[x0, y0],
    [x1, y1]]`` with ``count`` points (a ridge)."""
    name = t["name"] if t["name"] is not None else f"feature{i}"
    _plain_name(t, "name", name, "the feature's scatterers")
    if t.has("position") == t.has("line"):
        raise t.err("position", "give position = [x, y] (a point) or line = [[x0, y0], "
                    "[x1, y1]] with count (a ridge)")
    if t.has("position"):
        pts = np.asarray(t["position"], float).reshape(1, 2)
        _only(t, ("count",), "with line")
    else:
        ends = np.asarray(t["line"], float)
        if ends.shape != (2, 2):
            raise t.err("line", "must be two points [[x0, y0], [x1, y1]]")
        n = t["count"] if t["count"] is not None else 10
        u = np.linspace(0.0, 1.0, n) if n > 1 else np.array([0.5])
        pts = ends[0] + u[:, None] * (ends[1] - ends[0])
    return FeatureSpec(name, pts, t["depth"], t["ts_db"])


#: The motion keys of a target that follows its own track (not a [[source]]'s).
_MOTION_KEYS = ("start", "course", "speed", "speed_kn", "heading", "leg")


def _target(tt: Section, i: int, by_name: dict[str, SourceSpec]) -> TargetSpec:
    """One ``[[active.target]]``: its own track, or a ``source``'s."""
    name = tt["name"] if tt["name"] is not None else f"target{i}"
    _plain_name(tt, "name", name, "the target's truth rows")
    src = tt["source"]
    if src is not None:
        if src not in by_name:
            raise tt.err("source", f"no [[source]] named {src!r}")
        _only(tt, _MOTION_KEYS, "without source (the target follows the source's track)")
        traj, depth = by_name[src].traj, by_name[src].depth
        if tt["depth"] is not None:
            depth = tt["depth"]
    else:
        traj, _ = _trajectory(tt)
        depth = tt["depth"] if tt["depth"] is not None else 0.0
    length = tt["length"]
    nh = tt["highlights"] if tt["highlights"] is not None else (5 if length > 0 else 1)
    return TargetSpec(name, traj, depth, tt["ts_db"], tt["distortion_ms"] * 1e-3, src,
                      length, nh)


def _active(t: Section, fs: float, sources: list[SourceSpec], file: str) -> ActiveSpec:
    level = t["level_db"]
    several = t.has("waveforms") or t.has("times")
    waves, levels, sched, times = _schedule(t, fs, file, level)
    interval = t["interval"]
    if times is None and interval is None:
        raise t.err("interval", "missing (a number is required)")
    by_name = {s.name: s for s in sources}
    targets = [_target(tt, i, by_name) for i, tt in enumerate(t.subs("target"))]
    clutter = None
    ct = t.sub("clutter")
    if ct is not None:
        clutter = ClutterSpec(ct["count"], _area(ct), ct["depth"], ct["ts_mean_db"],
                              ct["ts_std_db"], ct["drift_speed_std"])
    reverb = [_reverb(rt) for rt in t.subs("reverberation")]
    features = [_feature(ft, i) for i, ft in enumerate(t.subs("feature"))]
    spec = ActiveSpec(waves, levels, sched, level, interval, t["first"], t["count"],
                      np.asarray(t["offset"], float), t["direct"], targets, clutter, times,
                      reverb, features)
    if several:
        _check_overlap(t, spec)
    return spec
