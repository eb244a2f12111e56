"""``arrayproc demo``: the main job end to end on the bundled examples, with its plots.

1. Towed array, passive: simulate ``data/scenarios/towed_passive.toml`` → process with
   ``data/chains/towed_passive.toml`` (DFT filter, CBF, integration, BTR, LOFAR, bearings) →
   BTR and LOFAR plots → track the merchant from its bearings with a UKF resolving the
   left-right ambiguity (``data/trackers/towed_demo.toml``) → track plot.
2. Passive synthetic aperture: simulate ``data/scenarios/towed_synthetic_aperture.toml`` (a
   weak 250 Hz tonal at cone 100°, a loud broadband source astern, lateral array motion) →
   BTR of the conventional beamformer (``data/chains/cbf_narrowband.toml``) beside the BTR of
   inverse beamforming + ETAM (``data/chains/ibf_etam.toml``).
3. Field data: import the six-hydrophone recording (when ``../shared/data`` is beside the
   checkout) → per-channel band power.
"""

from __future__ import annotations

import argparse
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from arrayproc.app import commands
from arrayproc.data import data_path
from arrayproc.errors import FormatError

DATA = data_path()

#: Seconds of the active scenario the demo simulates and processes (two pings).
ACTIVE_DEMO_S = 65.0


def field_recording_dir() -> Path | None:
    """The six-hydrophone field recording: ``$ARRAYPROC_XAV``, else ``shared/data/xav-large-array``
    beside the current directory or one of its parents (a checkout with ``../shared``)."""
    env = os.environ.get("ARRAYPROC_XAV")
    if env:
        return Path(env) if Path(env).is_dir() else None
    for d in (Path.cwd(), *Path.cwd().parents):
        for cand in (d / "shared" / "data" / "xav-large-array",
                     d.parent / "shared" / "data" / "xav-large-array"):
            if cand.is_dir():
                return cand
    return None


def _output_dir(outdir: str | os.PathLike) -> Path:
    out = Path(outdir)
    if not str(outdir).strip():
        raise FormatError("demo: output directory is empty")
    if out.exists() and not out.is_dir():
        raise FormatError(f"{out}: exists and is not a directory; give a directory for the "
                          "demo outputs")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise FormatError(f"{out}: cannot create the demo directory ({e.strerror})") from None
    return out


def run_demo(outdir: str | os.PathLike = "demo_out", progress: bool = False,
             echo: Callable[[str], None] = print) -> Path:
    """Run the demo: each step calls the library function of the matching command.

    Parameters
    ----------
    outdir : path-like
        Output directory (created; an existing file is refused).
    progress : bool
        Progress bars on stderr.
    echo : callable
        Where each step and each file's description are announced.

    Returns
    -------
    Path
        The output directory.
    """
    out = _output_dir(outdir)
    step = echo

    scenario = DATA / "scenarios" / "towed_passive.toml"
    chain = DATA / "chains" / "towed_passive.toml"
    if scenario.exists() and chain.exists():
        rec = out / "towed_passive.h5"
        prod = out / "towed_passive_products.h5"
        step(f"simulate {scenario.name} -> {rec}")
        commands.simulate(str(scenario), str(rec), progress=progress)
        step(f"process {rec.name} with {chain.name} -> {prod}")
        commands.process(str(rec), str(chain), str(prod), progress=progress)
        commands.info(str(prod), echo=echo)
        step(f"plot btr -> {out / 'btr.png'}")
        commands.plot(str(prod), str(out / "btr.png"), kind="btr")
        step(f"plot lofar (beam 56 deg) -> {out / 'lofar.png'}")
        commands.plot(str(prod), str(out / "lofar.png"), kind="lofar", beam=56.0)
        tracks = out / "towed_passive_tracks.h5"
        tracker = DATA / "trackers" / "multi_target.toml"
        step(f"track every contact of {prod.name} with {tracker.name} -> {tracks}")
        commands.track(str(prod), str(tracker), str(tracks), progress=progress)
        step(f"plot track -> {out / 'track.png'}")
        commands.plot(str(tracks), str(out / "track.png"), kind="track")
        step(f"plot metrics (GOSPA against truth) -> {out / 'track_metrics.png'}")
        commands.plot(str(tracks), str(out / "track_metrics.png"), kind="metrics")
        step(f"export {tracks.name} to Debrief REP -> {out / 'towed_passive_tracks.rep'}")
        commands.export([str(tracks)], "rep", str(out / "towed_passive_tracks.rep"))
        nb = out / "towed_passive_narrowband.h5"
        step(f"process {rec.name} with narrowband.toml -> {nb}")
        commands.process(str(rec), str(DATA / "chains" / "narrowband.toml"), str(nb),
                         progress=progress)
        step(f"plot nb_tracks -> {out / 'nb_tracks.png'}")
        commands.plot(str(nb), str(out / "nb_tracks.png"), kind="nb_tracks")
    scenario = DATA / "scenarios" / "towed_synthetic_aperture.toml"
    if scenario.exists():
        rec = out / "synthetic_aperture.h5"
        step(f"simulate {scenario.name} -> {rec}")
        commands.simulate(str(scenario), str(rec), progress=progress)
        for name in ("cbf_narrowband", "ibf_etam"):
            prod = out / f"synthetic_aperture_{name}.h5"
            step(f"process {rec.name} with {name}.toml -> {prod}")
            commands.process(str(rec), str(DATA / "chains" / f"{name}.toml"), str(prod),
                             progress=progress)
            step(f"plot btr -> {out / f'btr_{name}.png'}")
            commands.plot(str(prod), str(out / f"btr_{name}.png"), kind="btr")
    xav = field_recording_dir()
    if xav is not None:
        wavs = sorted(str(p) for p in xav.glob("AMAR173.*.wav"))
        geometry = xav / "hydrophones_config_07-HI.csv"
        rec = out / "xav.h5"
        step(f"import {len(wavs)} WAV files from {xav} -> {rec}")
        # the XAV configuration file's z axis points up: its deepest hydrophone (7.70 m in
        # deployment_info.csv) has the lowest z
        commands.import_wavs(wavs, str(rec), positions=commands.geometry(
            geometry_file=str(geometry), z_up=True), sound_speed=1484.0, inputs=[str(geometry)])
        commands.info(str(rec), echo=echo)
        step(f"process {rec.name} with power.toml -> {out / 'xav_power.h5'}")
        commands.process(str(rec), str(DATA / "chains" / "power.toml"),
                         str(out / "xav_power.h5"), progress=progress)
        commands.info(str(out / "xav_power.h5"), echo=echo)
        prod = out / "xav_localise.h5"
        step(f"process {rec.name} with xav_localise.toml -> {prod}")
        commands.process(str(rec), str(DATA / "chains" / "xav_localise.toml"), str(prod),
                         progress=progress)
        commands.info(str(prod), echo=echo)
        for kind, extra in (("detections", {"range_db": 50.0}), ("positions", {}),
                            ("delays", {})):
            step(f"plot {kind} -> {out / f'xav_{kind}.png'}")
            commands.plot(str(prod), str(out / f"xav_{kind}.png"), kind=kind, **extra)
        step(f"export detections to a Raven selection table -> {out / 'xav_detections.txt'}")
        commands.export([str(prod)], "raven", str(out / "xav_detections.txt"))
    scenario = DATA / "scenarios" / "active_bpsk.toml"
    chain = DATA / "chains" / "active.toml"
    if scenario.exists() and chain.exists():
        rec = out / "active_bpsk.h5"
        prod = out / "active_products.h5"
        step(f"simulate {scenario.name} (first {ACTIVE_DEMO_S:g} s) -> {rec}")
        commands.simulate(str(scenario), str(rec), duration=ACTIVE_DEMO_S, progress=progress)
        step(f"process {rec.name} with {chain.name} -> {prod}")
        commands.process(str(rec), str(chain), str(prod), progress=progress)
        commands.info(str(prod), echo=echo)
        step(f"plot contacts -> {out / 'active_contacts.png'}")
        commands.plot(str(prod), str(out / "active_contacts.png"), kind="contacts")
        step(f"plot range_doppler -> {out / 'active_range_doppler.png'}")
        commands.plot(str(prod), str(out / "active_range_doppler.png"), kind="range_doppler",
                      beam=50.0, range_db=30.0)
    return out


def _run(args: argparse.Namespace) -> int:
    from arrayproc.app.progress import Summary, bar_wanted, recording_seconds
    done = Summary.of(args)
    since = time.time()
    out = run_demo(args.output, progress=bar_wanted(args),
                   echo=commands.no_echo if args.quiet else print)
    made = [p for p in sorted(out.iterdir()) if p.is_file() and p.stat().st_mtime >= since - 1]
    audio = [a for a in map(recording_seconds, made) if a is not None]
    done(f"{out}/", f"{len(made)} files, {len(audio)} recordings", sum(audio) or None)
    return 0


def add_parser(sub: Any) -> None:
    """Register ``arrayproc demo`` on the command line's sub-parsers."""
    from arrayproc.app.options import add_no_progress, add_quiet
    s = sub.add_parser("demo", help="simulate, process, track and plot the bundled examples")
    s.add_argument("-o", "--output", default="demo_out", help="output directory")
    add_no_progress(s)
    add_quiet(s)  # no step lines and no summary line
    s.set_defaults(func=_run)
