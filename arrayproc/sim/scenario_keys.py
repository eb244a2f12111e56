"""The keys of a scenario file (``arrayproc simulate``), declared once.

Each table of a scenario TOML has one :class:`~arrayproc.config.Schema` here: type, default,
unit, doc and check of every key. :mod:`arrayproc.sim.scenario` reads a file through them
(:class:`~arrayproc.config.Section`), and :func:`markdown_tables` renders the key tables of
``docs/formats.md`` (kept equal by a test). Rules that tie keys together (one of two keys, a
default that depends on another key) are the reader's, and each is said in the key's doc.
"""

from __future__ import annotations

from typing import Any

from arrayproc.config import (
    Param,
    Schema,
    at_least,
    columns,
    length,
    markdown_header,
    non_negative,
    positive,
)

__all__ = ["SCENARIO", "SECTIONS", "markdown_tables", "MAX_LEVEL_DB"]

#: Largest source level accepted, dB re 1 µPa @ 1 m: far above any real source (about 270 dB
#: for the loudest explosions), low enough that 10^(L/20) stays finite in float64.
MAX_LEVEL_DB = 300.0


def physical_level(v: Any) -> str | None:
    """Check: a level whose magnitude is at most :data:`MAX_LEVEL_DB`."""
    if abs(v) > MAX_LEVEL_DB:
        return f"{v:g} dB is not a physical level (|level| <= {MAX_LEVEL_DB:g} dB)"
    return None


def _level(doc: str, unit: str = "dB re 1 µPa @ 1 m", required: bool = False) -> Param:
    if required:
        return Param("float", doc=doc, check=physical_level, unit=unit)
    return Param("float", None, doc, check=physical_level, unit=unit)


RECORDING = Schema({
    "fs": Param("float", doc="Sample rate.", check=positive, unit="Hz"),
    "duration": Param("float", doc="Length of the recording.", check=positive, unit="s"),
    "sound_speed": Param("float", 1500.0, "Sound speed (isovelocity).", check=positive,
                         unit="m/s"),
    "seed": Param("int", 0, "Root of every random stream; `simulate --seed` overrides it.",
                  check=at_least(0)),
    "start_time": Param("str", None, "ISO-8601 UTC time of the first sample, e.g. "
                        "\"2026-01-01T00:00:00Z\"."),
    "chunk": Param("int", 8192, "Samples per streamed chunk: bounds memory, never changes "
                   "the bytes.", check=at_least(64), unit="samples"),
    "truth_interval": Param("float", 1.0, "Time between `/truth` track samples.",
                            check=positive, unit="s"),
    "nav_interval": Param("float", 1.0, "Time between `/nav` fixes.", check=positive,
                          unit="s"),
}, "[recording]: sampling, length, sound speed and seed")

ARRAY = Schema({
    "type": Param("str", "line", "Element layout: `line` (n, spacing), `twin` (n, spacing, "
                  "separation), `triplet` (n, spacing, radius), `tetrahedron` (side) or "
                  "`positions`.", choices=("line", "positions", "tetrahedron", "twin",
                                           "triplet")),
    "n": Param("int", None, "Stations (line, twin, triplet); element 0 forward, the reference "
               "point at the array centre.", check=at_least(1)),
    "spacing": Param("float", None, "Station spacing (line, twin, triplet).", check=positive,
                     unit="m"),
    "separation": Param("float", None, "twin: the two lines at y = ∓separation/2 (port, "
                        "starboard per station).", check=positive, unit="m"),
    "radius": Param("float", None, "triplet: 3 hydrophones per station on this circle (top, "
                    "±120°).", check=positive, unit="m"),
    "side": Param("float", None, "tetrahedron: edge of the regular tetrahedron, centroid at "
                  "the reference, apex up.", check=positive, unit="m"),
    "positions": Param("rows", None, "positions: [[x, y, z], …] in the body frame (x forward, "
                       "y starboard, z down).", check=columns(3), unit="m"),
    "depth": Param("float", 0.0, "Depth of the reference point.", unit="m"),
    "position_error_std": Param("float", 0.0, "Fixed Gaussian error per element and axis (the "
                                "true positions in `/truth/array/positions`; "
                                "`/array/positions` stays nominal).", check=non_negative,
                                unit="m"),
    "lateral_std": Param("float", 0.0, "Lateral motion (thesis 2.2.2): Gaussian, equal for "
                         "every element, constant within each snapshot.", check=non_negative,
                         unit="m"),
    "lateral_snapshot": Param("float", 1.0, "Snapshot length of the lateral motion.",
                              check=positive, unit="s"),
    "yaw_std": Param("float", 0.0, "Heading jitter of a rigid array (a bed-mounted frame "
                     "rocking, a buoy's suspension): the true heading is the ownship's plus a "
                     "first-order Gauss-Markov yaw ψ(t) of this std, E ψ(t)ψ(t+Δ) = "
                     "σ² exp(−|Δ|/yaw_time), which `/nav` does not see, so the bearings' "
                     "errors are exponentially correlated; the yaw is in `/truth/array/yaw_deg`"
                     " (0: none; not with shape = water_pulled).", check=non_negative,
                     unit="deg"),
    "yaw_time": Param("float", 20.0, "Correlation time of the yaw.", check=positive,
                      unit="s"),
    "shape": Param("str", "rigid", "`water_pulled`: each element follows the path the "
                   "reference point took (threading model), so the array bends in turns; "
                   "needs an ownship moving on every leg; the shape is in "
                   "`/truth/array/element_positions`.", choices=("rigid", "water_pulled")),
}, "[array]: the element layout and its errors")

LEG = Schema({
    "course": Param("float", doc="Course of the leg (heading = course).", unit="deg"),
    "speed": Param("float", None, "Speed (or `speed_kn`).", check=non_negative, unit="m/s"),
    "speed_kn": Param("float", None, "Speed in knots (or `speed`).", check=non_negative,
                      unit="kn"),
    "duration": Param("float", doc="Length of the leg.", check=non_negative, unit="s"),
    "turn_rate": Param("float", None, "A coordinated turn at this rate at the leg's start "
                       "(inside its duration); none: the course changes at once.",
                       check=positive, unit="deg/s"),
    "turn": Param("str", None, "Direction of the turn (default the shortest).",
                  choices=("shortest", "port", "starboard")),
}, "[[….leg]]: one leg of a track")

_MOTION = {
    "start": Param("floats", [0.0, 0.0], "Position at t = 0: x east, y north.",
                   check=length(2), unit="m"),
    "course": Param("float", None, "One straight leg: its course (with `speed`/`speed_kn`).",
                    unit="deg"),
    "speed": Param("float", None, "One straight leg: its speed (or `speed_kn`).",
                   check=non_negative, unit="m/s"),
    "speed_kn": Param("float", None, "One straight leg: its speed in knots (or `speed`).",
                      check=non_negative, unit="kn"),
    "heading": Param("float", None, "A static track's heading (default 0); not with "
                     "course/speed/legs.", unit="deg"),
    "leg": Param("tables", [], "Legs in order (`[[….leg]]`), instead of course/speed.",
                 schema=LEG),
}

OWNSHIP = Schema(_MOTION, "[ownship]: the array reference point's track (no table: static "
                 "at the origin, heading 0)")

TONAL = Schema({
    "freq": Param("float", doc="Frequency (at t = 0 with a drift); below 0.45·fs.",
                  check=positive, unit="Hz"),
    "level_db": _level("Source level (RMS).", required=True),
    "phase_deg": Param("float", None, "Phase at t = 0 (none: random, seeded).", unit="deg"),
    "drift_hz_per_s": Param("float", 0.0, "Linear drift, f(t) = freq + drift·t at emission "
                            "time t.", unit="Hz/s"),
    "coherence_time": Param("float", None, "Random-walk phase, |E e^{iΔφ(τ)}| = "
                            "exp(−τ/T_c); at least 50 grid nodes of 8/fs s (none: coherent).",
                            check=positive, unit="s"),
    "fading_db": Param("float", 0.0, "Std of a log-amplitude Gauss-Markov fade (mean power "
                       "kept; 0: steady).", check=non_negative, unit="dB"),
    "fading_time": Param("float", 10.0, "Correlation time of the fade.", check=positive,
                         unit="s"),
}, "tonals = [{…}, …]: one tonal of a source")

BROADBAND = Schema({
    "band": Param("floats", doc="[lo, hi] with 0 <= lo < hi <= 0.45·fs.", check=length(2),
                  unit="Hz"),
    "model": Param("str", "flat", "`flat` (level_db) or `speed`: SPL paper eq. (12), band "
                   "level 170 + 53 log10(v / 5.14 m/s) dB re 1 µPa @ 1 m spread over the band.",
                   choices=("flat", "speed")),
    "level_db": _level("Spectral source level (model flat; not with speed).",
                       unit="dB re 1 µPa²/Hz @ 1 m"),
    "slope_db_per_octave": Param("float", 0.0, "Tilt within the band, relative to its lower "
                                 "edge.", unit="dB/octave"),
}, "[….broadband]: Gaussian band-limited noise of a source")

SOURCE = Schema({
    "name": Param("str", None, "Plain name (default `source<i>`): it names the source's "
                  "`/truth` group."),
    **_MOTION,
    "depth": Param("float", 0.0, "Depth.", unit="m"),
    "tonals": Param("tables", [], "Tonals ({freq, level_db, …} each).", schema=TONAL),
    "broadband": Param("table", None, "Broadband noise (a source needs tonals or this).",
                       schema=BROADBAND),
}, "[[source]]: a radiating source (any number; the motion keys of [ownship])")

MULTIPATH = Schema({
    "surface": Param("bool", True, "A pressure-release surface (R = −1)."),
    "bottom_depth": Param("float", None, "A flat bottom at this depth (none: no bottom).",
                          check=positive, unit="m"),
    "bottom_loss_db": Param("float", 0.0, "Loss per bottom bounce.", check=non_negative,
                            unit="dB"),
    "order": Param("int", 1, "Most reflections per path (1: direct, surface and bottom "
                   "paths).", check=at_least(0)),
    "surface_rms_height": Param("float", 0.0, "Rough surface: each bounce × exp(−Γ²/2), "
                                "Γ = 2kσ sin θ (needs surface and roughness_freq).",
                                check=non_negative, unit="m"),
    "roughness_freq": Param("float", 0.0, "Frequency of the Rayleigh parameter's k.",
                            check=non_negative, unit="Hz"),
}, "multipath = {…}: image sources in a flat waveguide (needs loss = \"spherical\"); every "
   "path has its own travel time, spreading and Doppler")

BELLHOP = Schema({
    "depth": Param("float", None, "Flat bottom (none: the bundled TL tables' Munk "
                   "environment, 1000 m).", check=positive, unit="m"),
    "freq": Param("float", None, "Frequency of the ray trace (none: the loudest tonal's, "
                  "else the first band's centre).", check=positive, unit="Hz"),
    "max_range": Param("float", None, "Largest range (none: 1.2 × the largest source range "
                       "+ 100 m).", check=positive, unit="m"),
    "range_step": Param("float", 10.0, "Arrivals every range_step, linear in between.",
                        check=positive, unit="m"),
    "ssp": Param("rows", None, "Sound-speed profile [[depth, speed], …] from 0 to depth "
                 "(none: isovelocity).", check=columns(2), unit="m, m/s"),
    "bottom_speed": Param("float", 1600.0, "Halfspace sound speed.", check=positive,
                          unit="m/s"),
    "bottom_density": Param("float", 1.8, "Halfspace density.", check=positive,
                            unit="g/cm³"),
    "bottom_atten": Param("float", None, "Halfspace attenuation (none: 0.5, or 0.8 in the "
                          "Munk environment).", check=non_negative, unit="dB/λ"),
    "n_beams": Param("int", 0, "Rays traced (0: BELLHOP chooses).", check=at_least(0)),
}, "[propagation.bellhop]: the environment of multipath = \"bellhop\" (passive sources)")

PROPAGATION = Schema({
    "loss": Param("str", "spherical", "`spherical` 20 log10 r, `cylindrical` (spherical to "
                  "transition_range, then + 10 log10(r / r_t)) or `table`.",
                  choices=("spherical", "cylindrical", "table")),
    "transition_range": Param("float", 1.0, "cylindrical: the spherical-to-cylindrical "
                              "range.", check=positive, unit="m"),
    "file": Param("str", None, "table: a TL table file (`arrayproc.acoustics.tl`), relative "
                  "to the scenario, read at each source's and the array's depth."),
    "range_m": Param("floats", None, "table: an inline TL(range), increasing (with tl_db).",
                     unit="m"),
    "tl_db": Param("floats", None, "table: the inline TL at range_m, linear in between.",
                   unit="dB"),
    "multipath": Param("any", None, "Image sources {surface, bottom_depth, …} or `bellhop`: "
                       "BELLHOP's eigenrays (needs bellhopcxx).", schema=MULTIPATH),
    "bellhop": Param("table", None, "Environment of multipath = \"bellhop\".",
                     schema=BELLHOP),
}, "[propagation]: the loss law and multipath")

TOWSHIP = Schema({
    "distance": Param("float", 300.0, "Ahead of the array on its track (negative: behind); "
                      "it arrives from forward end-fire.", unit="m"),
    "depth": Param("float", 5.0, "Depth.", unit="m"),
    "tonals": Param("tables", [], "Tonals ({freq, level_db, …} each).", schema=TONAL),
    "broadband": Param("table", None, "Broadband noise (tonals or this).", schema=BROADBAND),
}, "[noise.towship]: a tow ship on the ownship's track")

NOISE = Schema({
    "level_db": Param("float", None, "Ambient noise, independent on every element, flat.",
                      unit="dB re 1 µPa²/Hz"),
    "spectrum": Param("rows", None, "Or coloured: [[Hz, dB], …], frequencies > 0 and "
                      "increasing, linear in dB against log f.", check=columns(2)),
    "towship": Param("table", None, "A tow ship.", schema=TOWSHIP),
}, "[noise]: ambient noise and the tow ship")

_WAVE = {
    "waveform": Param("str", None, "`bpsk` (fc, bits = 2**m − 1), `hfm` (f0, f1) or `cw` "
                      "(fc).", choices=("bpsk", "hfm", "cw")),
    "duration": Param("float", None, "Pulse length.", check=positive, unit="s"),
    "taper": Param("float", 0.05, "Tukey fraction of the pulse.", check=non_negative,
                   unit="fraction"),
    "fc": Param("float", None, "bpsk, cw: carrier.", check=positive, unit="Hz"),
    "bits": Param("int", 1023, "bpsk: code length.", check=at_least(3)),
    "f0": Param("float", None, "hfm: start frequency.", check=positive, unit="Hz"),
    "f1": Param("float", None, "hfm: end frequency.", check=positive, unit="Hz"),
}

WAVEFORM = Schema({**_WAVE, "level_db": _level("Source level of this waveform (default "
                                               "[active] level_db).")},
                  "[active.waveforms.<name>]: one named waveform (replica "
                  "/active/waveforms/<name>)")

TARGET = Schema({
    "name": Param("str", None, "Plain name (default `target<i>`) of the truth rows."),
    "source": Param("str", None, "Reuse this [[source]]'s track (no motion keys then)."),
    **_MOTION,
    "depth": Param("float", None, "Depth (default 0, or the source's).", unit="m"),
    "ts_db": Param("float", doc="Target strength.", unit="dB"),
    "distortion_ms": Param("float", 0.0, "Thesis eq. (4.6) time-distortion amplitude α "
                           "(Doppler spread).", check=non_negative, unit="ms"),
    "length": Param("float", 0.0, "An extended target: `highlights` point scatterers along "
                    "its course axis, each TS − 10 log10(highlights).", check=non_negative,
                    unit="m"),
    "highlights": Param("int", None, "Highlights of an extended target (default 5; 1 for a "
                        "point).", check=at_least(1)),
}, "[[active.target]]: an echoing target")

CLUTTER = Schema({
    "count": Param("int", doc="Static point scatterers, uniform in the area.",
                   check=at_least(0)),
    "area": Param("floats", doc="[x min, x max, y min, y max].", check=length(4), unit="m"),
    "depth": Param("float", 0.0, "Depth.", unit="m"),
    "ts_mean_db": Param("float", -10.0, "Target strengths ~ Normal(mean, std) in dB.",
                        unit="dB"),
    "ts_std_db": Param("float", 5.0, "Std of the target strengths.", check=non_negative,
                       unit="dB"),
    "drift_speed_std": Param("float", 0.0, "Drifting clutter (fish schools, advected "
                             "scatterers): each point moves at a constant horizontal velocity "
                             "drawn N(0, σ²) per axis (seeded), so its radial speed is N(0, σ²) "
                             "and its echo has its own Doppler; 0: static points.",
                             check=non_negative, unit="m/s"),
}, "[active.clutter]: point clutter, static or drifting")

REVERB = Schema({
    "boundary": Param("str", "bottom", "The scattering boundary.",
                      choices=("bottom", "surface")),
    "depth": Param("float", None, "The boundary's depth (bottom: required; surface: 0).",
                   unit="m"),
    "scattering_strength_db": Param("float", doc="Lambert's 10 log10 μ: S = 10 log10 μ + "
                                    "10 log10(sin θi sin θs).", unit="dB"),
    "density": Param("float", doc="Random scatterers per m² (seeded), each standing for "
                     "1/density m²; at most 200 000 over the area.", check=positive,
                     unit="1/m²"),
    "area": Param("floats", doc="[x min, x max, y min, y max].", check=length(4), unit="m"),
}, "[[active.reverberation]]: boundary reverberation")

FEATURE = Schema({
    "name": Param("str", None, "Plain name (default `feature<i>`)."),
    "position": Param("floats", None, "A point [x, y] (a wreck); or line.", check=length(2),
                      unit="m"),
    "line": Param("rows", None, "[[x0, y0], [x1, y1]]: `count` points along it (a ridge).",
                  check=columns(2), unit="m"),
    "count": Param("int", None, "Points along the line (default 10).", check=at_least(1)),
    "depth": Param("float", doc="Depth.", unit="m"),
    "ts_db": Param("float", doc="Target strength per point.", unit="dB"),
}, "[[active.feature]]: a static bottom feature")

ACTIVE = Schema({
    **_WAVE,
    "level_db": _level("Source level (RMS of the carrier).", required=True),
    "waveforms": Param("table", None, "Several waveforms: one [active.waveforms.<name>] table "
                       "each, instead of the waveform keys here.", schema=WAVEFORM),
    "schedule": Param("any", None, "Waveform names cycled over the pings: ping k uses "
                      "schedule[k mod n]."),
    "times": Param("floats", None, "Explicit increasing transmission times, instead of "
                   "interval/first/count.", unit="s"),
    "interval": Param("float", None, "Time between pings (required without times).",
                      check=positive, unit="s"),
    "first": Param("float", 0.0, "First ping.", check=non_negative, unit="s"),
    "count": Param("int", None, "Number of pings (default: as many as fit).",
                   check=at_least(1)),
    "offset": Param("floats", [0.0, 0.0, 0.0], "Projector in the array's body frame.",
                    check=length(3), unit="m"),
    "direct": Param("bool", True, "Include the direct blast."),
    "target": Param("tables", [], "Targets.", schema=TARGET),
    "clutter": Param("table", None, "Static point clutter.", schema=CLUTTER),
    "reverberation": Param("tables", [], "Boundary reverberation.", schema=REVERB),
    "feature": Param("tables", [], "Bottom features.", schema=FEATURE),
}, "[active]: an active sonar's pings, targets and clutter")

SCENARIO = Schema({
    "recording": Param("table", None, "Required.", schema=RECORDING),
    "array": Param("table", None, "Required.", schema=ARRAY),
    "ownship": Param("table", None, "The array's track.", schema=OWNSHIP),
    "source": Param("tables", [], "Sources.", schema=SOURCE),
    "propagation": Param("table", None, "Loss law and multipath.", schema=PROPAGATION),
    "noise": Param("table", None, "Ambient noise, tow ship.", schema=NOISE),
    "active": Param("table", None, "Active sonar.", schema=ACTIVE),
}, "a scenario file")

#: Every table of a scenario file, in documentation order: (heading, schema).
SECTIONS: tuple[tuple[str, Schema], ...] = (
    ("[recording]", RECORDING), ("[array]", ARRAY), ("[ownship]", OWNSHIP),
    ("[[ownship.leg]], [[source.leg]], [[active.target.leg]]", LEG), ("[[source]]", SOURCE),
    ("tonals", TONAL), ("[source.broadband], [noise.towship.broadband]", BROADBAND),
    ("[propagation]", PROPAGATION), ("[propagation] multipath", MULTIPATH),
    ("[propagation.bellhop]", BELLHOP), ("[noise]", NOISE), ("[noise.towship]", TOWSHIP),
    ("[active]", ACTIVE), ("[active.waveforms.NAME]", WAVEFORM),
    ("[[active.target]]", TARGET), ("[active.clutter]", CLUTTER),
    ("[[active.reverberation]]", REVERB), ("[[active.feature]]", FEATURE),
)


def markdown_tables() -> str:
    """The scenario key tables of ``docs/formats.md``: one table of every scenario table's
    keys (key, type, default, unit, description), generated from the declarations.

    Returns
    -------
    str
        Markdown, a ``table`` column naming the TOML table on its first row.
    """
    lines = markdown_header(True, "table")
    for heading, schema in SECTIONS:
        lines.append(schema.markdown(first=heading))
    return "\n".join(lines)
