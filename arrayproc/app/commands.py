"""The core sub-commands of ``arrayproc`` on the command line: their parsers and the glue that
turns parsed arguments into a call of the library function and a summary line.

The commands themselves are plain library functions with typed arguments, one module each:
:func:`~arrayproc.app.describe.info`, :func:`~arrayproc.app.process.process`,
:func:`~arrayproc.app.recordings.import_wavs` and :func:`~arrayproc.app.recordings.simulate`,
:func:`~arrayproc.app.plotting.plot`, :func:`~arrayproc.app.tracking.track` and
:func:`~arrayproc.app.tracking.tma`, :func:`~arrayproc.app.export.export`. None reads
``sys.argv`` and none prints except through the ``echo`` / ``warn`` callables it is given, so
the demo and other programs call them directly; they are importable from this module too.

Every command checks its output path against its inputs before any work
(:func:`arrayproc.io.atomic.check_output`). The options that several commands share are
declared once (:mod:`arrayproc.app.options`), so ``-c``, ``-o`` and ``-q`` mean one thing on
every command. Heavy modules (scipy, numba kernels, matplotlib) are imported inside the
commands that use them, so ``--version`` and ``info`` start quickly.
"""

from __future__ import annotations

import argparse
import importlib
from typing import Any

from arrayproc.app.options import (
    add_calibration_options,
    add_config,
    add_geometry_options,
    add_no_progress,
    add_output,
    add_quiet,
    geometry,
    geometry_inputs,
    geometry_of,
)
from arrayproc.app.progress import (
    Echo,
    Summary,
    audio_seconds,
    bar_wanted,
    no_echo,
    products_what,
    recording_what,
)
from arrayproc.io.atomic import check_output

#: The library functions, imported on first use (building the parser stays cheap: the
#: modules behind ``info`` alone import h5py and numpy).
_LIBRARY = {
    "info": "arrayproc.app.describe",
    "process": "arrayproc.app.process",
    "latency_line": "arrayproc.app.process",
    "import_wavs": "arrayproc.app.recordings",
    "simulate": "arrayproc.app.recordings",
    "start_time_from_names": "arrayproc.app.recordings",
    "plot": "arrayproc.app.plotting",
    "default_plot_kind": "arrayproc.app.plotting",
    "PLOT_PRIORITY": "arrayproc.app.plotting",
    "check_plot_input": "arrayproc.app.inputs",
    "check_product_input": "arrayproc.app.inputs",
    "PLOT_INPUTS": "arrayproc.app.inputs",
    "TRACK_INPUT": "arrayproc.app.inputs",
    "track": "arrayproc.app.tracking",
    "tma": "arrayproc.app.tracking",
    "tracks_summary": "arrayproc.app.tracking",
    "export": "arrayproc.app.export",
    "report": "arrayproc.app.report",
}

__all__ = ["Echo", "add_geometry_options", "add_parser", "geometry", *_LIBRARY]

_quiet = no_echo  # the name the demo used


def __getattr__(name: str) -> Any:
    mod = _LIBRARY.get(name)
    if mod is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(mod), name)
    globals()[name] = value
    return value


# -- run: parsed arguments -> library call -> summary line ----------------------------------
def _run_info(args: argparse.Namespace) -> int:
    from arrayproc.app.describe import info
    info(args.file, positions=geometry_of(args), echo=no_echo if args.quiet else print)
    return 0


def _run_process(args: argparse.Namespace) -> int:
    from arrayproc.app.process import latency_line, process
    from arrayproc.app.resources import parse_bytes
    from arrayproc.errors import ConfigError
    done = Summary.of(args)
    check_output(args.output, [args.recording, args.config, *geometry_inputs(args)])
    limit = parse_bytes(args.max_memory) if args.max_memory is not None else None
    if args.idle is not None and not args.follow:
        raise ConfigError("--idle needs --follow")
    stats: list = []
    n = process(args.recording, args.config, args.output, positions=geometry_of(args),
                nan=args.nan, progress=bar_wanted(args) and not args.follow,
                max_memory=limit, follow=args.follow,
                idle_s=10.0 if args.idle is None else args.idle, stats=stats)
    if stats and not args.quiet:
        print(latency_line(stats[0]))
    done(args.output, f"{products_what(args.output)}, {n} block{'s' * (n != 1)}",
         audio_seconds(args.recording))
    return 0


def _run_import(args: argparse.Namespace) -> int:
    from arrayproc.app.recordings import import_wavs
    done = Summary.of(args)
    check_output(args.output, [*args.wav, *geometry_inputs(args)])
    r = import_wavs(args.wav, args.output, positions=geometry_of(args), scale=args.scale,
                    sound_speed=args.sound_speed, start_time=args.start_time,
                    inputs=geometry_inputs(args), sensitivity_db=args.sensitivity,
                    gain_db=args.gain, full_scale_volts=args.full_scale_volts,
                    response=args.response)
    done(args.output, f"{recording_what(args.output)}, {r['format']}",
         audio_seconds(args.output))
    return 0


def _run_simulate(args: argparse.Namespace) -> int:
    from arrayproc.app.recordings import simulate
    done = Summary.of(args)
    simulate(args.scenario, args.output, seed=args.seed, duration=args.duration,
             progress=bar_wanted(args))
    done(args.output, recording_what(args.output), audio_seconds(args.output))
    return 0


def _run_plot(args: argparse.Namespace) -> int:
    from arrayproc.app.plotting import plot
    kind = plot(args.file, args.output, kind=args.kind, beam=args.beam,
                range_db=args.range_db, truth=not args.no_truth, t0=args.t0, t1=args.t1,
                fmin=args.fmin, fmax=args.fmax, channel=args.channel)
    if not args.quiet:
        print(f"{args.output}: {kind} plot written")
    return 0


def _run_track(args: argparse.Namespace) -> int:
    from arrayproc.app.tracking import track, tracks_summary
    done = Summary.of(args)
    track(args.products, args.config, args.output, progress=bar_wanted(args))
    done(args.output, tracks_summary(args.output), audio_seconds(args.output))
    return 0


def _run_tma(args: argparse.Namespace) -> int:
    from arrayproc.app.tracking import tma
    done = Summary.of(args)
    tma(args.products, args.config, args.output, progress=bar_wanted(args))
    done(args.output, products_what(args.output), audio_seconds(args.output))
    return 0


def _run_export(args: argparse.Namespace) -> int:
    from arrayproc.app.export import export
    done = Summary.of(args)
    n = export(args.files, args.to, args.output, origin=tuple(args.origin))
    audio = [audio_seconds(f) for f in args.files]
    unit = {"raven": "selections", "rep": "lines"}.get(args.to, "groups")
    done(args.output, f"{n} {unit}",
         sum(audio) if all(a is not None for a in audio) else None)
    return 0


def _run_data_dir(args: argparse.Namespace) -> int:
    from arrayproc.data import data_path
    d = data_path()
    if not args.quiet:
        print(d)
    return 0


# -- parsers ----------------------------------------------------------------------------------
def _add_info(sub: Any) -> None:
    s = sub.add_parser("info", help="describe a recording or products file")
    s.add_argument("file", help="recording or products HDF5 file")
    add_geometry_options(s)
    s.add_argument("--nan", choices=("error", "zero"), default="error",
                   help="accepted as in process; info reads no samples, so it has no effect")
    add_quiet(s)
    s.set_defaults(func=_run_info)


def _add_process(sub: Any) -> None:
    s = sub.add_parser("process", help="run a processing chain over a recording")
    s.add_argument("recording", help="recording HDF5 file")
    add_config(s, "chain TOML file", alias="--chain")
    add_output(s, "products HDF5 file to write")
    add_no_progress(s)
    add_quiet(s)
    s.add_argument("--max-memory", default=None, metavar="SIZE",
                   help="refuse a chain whose estimated working memory exceeds SIZE (bytes, or "
                        "with a unit: 500M, 4G; default: half the machine's RAM)")
    add_geometry_options(s)
    s.add_argument("--nan", choices=("error", "zero"), default="error",
                   help="NaN/Inf samples: stop with an error (default) or zero them")
    s.add_argument("--follow", action="store_true",
                   help="the recording is still being written (HDF5 SWMR): process each "
                        "block as it completes, write the products live, stop after --idle "
                        "seconds without new samples or at a signal")
    s.add_argument("--idle", type=float, default=None, metavar="S",
                   help="with --follow: stop after S seconds without new samples (default 10)")
    s.set_defaults(func=_run_process)


def _add_import(sub: Any) -> None:
    s = sub.add_parser("import", help="turn WAV, FLAC or AIFF field recordings into a "
                       "recording file")
    s.add_argument("wav", nargs="+", help="one multichannel audio file (WAV, FLAC, AIFF, …) or "
                   "one mono file per hydrophone (channels in the natural order of the names: "
                   "hyd2 before hyd10)")
    add_output(s, "recording HDF5 file to write")
    s.add_argument("--scale", type=float, default=None,
                   help="pascals per full scale (default: store full-scale units)")
    add_calibration_options(s)
    s.add_argument("--sound-speed", type=float, default=1500.0, help="m/s (default 1500)")
    s.add_argument("--start-time", default=None, help="ISO-8601 UTC start (default: from the "
                   "file name when it holds one, e.g. 20190920T163858Z)")
    add_quiet(s)
    add_geometry_options(s)
    s.set_defaults(func=_run_import)


def _add_simulate(sub: Any) -> None:
    s = sub.add_parser("simulate", help="simulate a recording from a scenario TOML")
    s.add_argument("scenario", help="scenario TOML file")
    add_output(s, "recording HDF5 file to write")
    s.add_argument("--seed", type=int, default=None, help="overrides the scenario's seed")
    s.add_argument("--duration", type=float, default=None, help="shorten the scenario (s)")
    add_no_progress(s)
    add_quiet(s)
    s.set_defaults(func=_run_simulate)


def _add_plot(sub: Any) -> None:
    s = sub.add_parser("plot", help="plot a products, tracks or recording file")
    s.add_argument("file", help="products or tracks HDF5 file (a recording for the "
                   "spectrogram and geometry plots)")
    s.add_argument("--kind", default=None, help="btr, lofar, bearings, bearing_frequency, "
                   "spectrogram, geometry, track, … (default: the first found)")
    s.add_argument("--beam", type=float, default=None, help="cone angle (deg) for LOFAR")
    s.add_argument("--range-db", type=float, default=20.0, help="displayed dynamic range, dB")
    s.add_argument("--no-truth", action="store_true", help="no truth overlay")
    for flag, what in (("--t0", "start of the time window shown, s since the recording's "
                        "start"), ("--t1", "end of the time window shown, s"),
                       ("--fmin", "lowest frequency shown, Hz"),
                       ("--fmax", "highest frequency shown, Hz")):
        s.add_argument(flag, type=float, default=None, help=what + " (time/frequency plots)")
    s.add_argument("--channel", type=int, default=None,
                   help="channel of the spectrogram (default 0) or detections plot")
    add_output(s, "image file; the extension names the format (.png, .pdf, .svg, …)")
    add_quiet(s)
    s.set_defaults(func=_run_plot)


def _add_track(sub: Any) -> None:
    s = sub.add_parser("track", help="track targets from a products file's measurements")
    s.add_argument("products", nargs="+", help="products HDF5 file with the measurements; "
                   "measurements = \"fused_bearings\": two or more, one per static array, "
                   "each naming its recording (the array's position)")
    add_config(s, "tracker TOML file")
    add_output(s, "tracks HDF5 file to write")
    add_no_progress(s)
    add_quiet(s)
    s.set_defaults(func=_run_track)


def _add_tma(sub: Any) -> None:
    s = sub.add_parser("tma", help="batch ML target motion analysis (bearings, bearings + "
                       "frequency, delays, compact, or the cross-fix of several static "
                       "arrays) with Cramér-Rao bounds")
    s.add_argument("products", nargs="+", help="products HDF5 file with bearings, lines or "
                   "delays, or a multi-target tracks file (one solution per confirmed track); "
                   "method = \"cross_fix\": two or more products files, one per static "
                   "array, each naming its recording (the array's position), or two such "
                   "arrays' tracks files (their tracks paired across the arrays), or one tracks "
                   "file of the fused tracker (one solution per confirmed track)")
    add_config(s, "TMA TOML file")
    add_output(s, "products HDF5 file to write")
    add_no_progress(s)
    add_quiet(s)
    s.set_defaults(func=_run_tma)


def _add_export(sub: Any) -> None:
    s = sub.add_parser("export", help="write Raven selection tables, Debrief REP files, or "
                       "NetCDF4/Zarr labelled arrays")
    s.add_argument("files", nargs="+", help="products files (raven: in time order) or one "
                   "tracks file (rep), one products or tracks file (netcdf, zarr)")
    s.add_argument("--to", required=True, choices=("raven", "rep", "netcdf", "zarr"),
                   help="raven: selection table; rep: Debrief replay file; netcdf: NetCDF4 "
                        "file, zarr: Zarr store, one group per products group")
    add_output(s, "file to write (a directory for zarr)")
    s.add_argument("--origin", type=float, nargs=2, default=(0.0, 0.0),
                   metavar=("LAT", "LON"), help="rep: latitude/longitude of x = y = 0 (deg)")
    add_quiet(s)
    s.set_defaults(func=_run_export)


def _add_data_dir(sub: Any) -> None:
    s = sub.add_parser("data-dir", help="print the folder of the bundled chains, scenarios, "
                       "trackers and TMA configurations")
    add_quiet(s)
    s.set_defaults(func=_run_data_dir)


def add_parser(sub: Any) -> None:
    """Register this module's sub-commands (info, process, import, simulate, plot, track, tma,
    export, data-dir) on the command line's sub-parsers (the demo registers itself, app/demo.py)."""
    for add in (_add_info, _add_process, _add_import, _add_simulate, _add_plot, _add_track,
                _add_tma, _add_export, _add_data_dir):
        add(sub)
