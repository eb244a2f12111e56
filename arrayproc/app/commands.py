"""The commands of ``arrayproc`` as plain library functions with typed arguments.

Each function does one command's job and returns what it made; none reads ``sys.argv`` and
none prints except through the ``echo`` / ``warn`` callables it is given, so the demo and
other programs call them directly. :func:`add_parser` registers their sub-commands on the
command line (:mod:`arrayproc.app.cli`).

Every command checks its output path against its inputs before any work
(:func:`arrayproc.io.atomic.check_output`): an output that is an input (same file through a
symlink or a hard link too) or that is not a regular file is refused. Heavy modules (scipy,
numba kernels, matplotlib) are imported inside the commands that use them, so ``--version``
and ``info`` start quickly.
"""

from __future__ import annotations

import argparse
import math
import re
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from arrayproc.app.progress import Summary, audio_seconds, bar_wanted, products_what, recording_what
from arrayproc.errors import ArrayprocError, ConfigError, FormatError
from arrayproc.io.atomic import check_output

Echo = Callable[[str], None]


def _stderr(msg: str) -> None:
    print(f"arrayproc: warning: {msg}", file=sys.stderr)


def _quiet(msg: str) -> None:
    """An ``echo`` that prints nothing."""


# -- geometry ---------------------------------------------------------------------------------
def geometry(line: Sequence[float] | None = None, geometry_file: str | None = None,
             z_up: bool = False):
    """Element positions from ``--line N SPACING`` or a geometry file, else None.

    Parameters
    ----------
    line : (N, spacing), optional
        Uniform line array of N elements, spacing m apart.
    geometry_file : str, optional
        CSV (x, y, z columns) or acoular XML file of positions, m.
    z_up : bool
        The file's z axis points up (arrayproc's body frame has z down): z is negated.

    Returns
    -------
    ndarray (n, 3) or None
        Body-frame positions, m.
    """
    from arrayproc.io.geometry import line_array, read_geometry
    if line is not None:
        n, spacing = line
        if not (n == int(n) if _finite(n) else False) or not 1 <= n <= 1_000_000:
            raise FormatError(f"--line N SPACING: N must be a whole number in 1..1000000, "
                              f"got {n:g}")
        if not (_finite(spacing) and spacing > 0):
            raise FormatError(f"--line N SPACING: SPACING must be a finite number > 0 m, "
                              f"got {spacing:g}")
        return line_array(int(n), spacing)
    if geometry_file:
        pos = read_geometry(geometry_file)
        if z_up:
            pos = pos.copy()
            pos[:, 2] = -pos[:, 2]
        return pos
    return None


def _finite(v: float) -> bool:
    return v == v and v not in (float("inf"), float("-inf"))


# -- info -------------------------------------------------------------------------------------
def info(path: str, positions: Any = None, echo: Echo = print) -> None:
    """Describe a recording or a products file, cheaply on any file.

    Only attributes, shapes and small datasets are read (never the samples); the aperture of
    n elements costs O(n) memory.

    Parameters
    ----------
    path : str
        Recording or products HDF5 file.
    positions : (n, 3) array, optional
        Geometry for a file that has none (acoular layout).
    echo : callable
        Where each line of the description goes.
    """
    from arrayproc.app.describe import describe
    for line in describe(path, positions):
        echo(line)


# -- process ----------------------------------------------------------------------------------
def process(recording: str, chain: str, output: str, positions: Any = None,
            nan: str = "error", progress: bool = False, max_memory: float | None = None,
            warn: Echo = _stderr, follow: bool = False, idle_s: float = 10.0,
            stats: list | None = None) -> int:
    """Run a processing chain over a recording into a products file.

    Parameters
    ----------
    recording : str
        Recording HDF5 file.
    chain : str
        Chain TOML file.
    output : str
        Products HDF5 file to write (atomically: it appears whole or not at all).
    positions : (n, 3) array, optional
        Geometry overriding or supplying the file's (m).
    nan : {"error", "zero"}
        NaN/Inf samples: stop, or replace by zeros with a warning.
    progress : bool
        Progress bar on stderr, in seconds of audio.
    max_memory : float, optional
        Refuse a chain whose estimated working memory exceeds this many bytes (default: half
        the machine's RAM).
    warn : callable
        Where warnings go.
    follow : bool
        The recording is still being written (HDF5 SWMR): process each block as soon as it
        is complete, write the products live (SWMR, readable while they grow) and stop after
        ``idle_s`` seconds without new samples or at a signal, leaving a complete file
        (:mod:`arrayproc.chain.follow`).
    idle_s : float
        See ``follow``.
    stats : list, optional
        Receives the :class:`arrayproc.chain.follow.FollowStats` of a followed run.

    Returns
    -------
    int
        Number of time blocks processed.
    """
    check_output(output, [recording, chain])
    if follow and not (math.isfinite(idle_s) and idle_s > 0):
        raise ConfigError(f"--idle must be a number of seconds > 0, got {idle_s}")
    from arrayproc.app.resources import check_chain_memory
    from arrayproc.config import read_toml
    from arrayproc.io.recording import Recording
    with Recording(recording, positions=positions, nan=nan, swmr=follow) as r:
        raw, text = read_toml(chain, "chain")  # read once
        # before any stage is built: parameters can ask for terabytes
        check_chain_memory(chain, raw, r.n_channels, r.fs, max_memory)
        from arrayproc.app.api import chain_from_toml, run_chain
        from arrayproc.io.products import ProductsWriter
        spec = chain_from_toml(raw, text, chain)  # validated before any data is read
        if follow:
            n = _follow(r, spec, recording, output, idle_s, warn, stats)
        else:
            with ProductsWriter(output, source=str(Path(recording).resolve()),
                                chain=spec.text) as out:
                n = run_chain(r, spec, out, progress=progress, log=warn)
        if r.n_nonfinite:
            warn(f"{recording}: {r.n_nonfinite} NaN/Inf samples replaced by zeros")
    return n


def _follow(r: Any, spec: Any, recording: str, output: str, idle_s: float, warn: Echo,
            stats: list | None) -> int:
    """``process --follow``: the live products file, stop requests ending the stream."""
    from arrayproc.chain.follow import follow_chain
    from arrayproc.io.atomic import set_graceful
    from arrayproc.io.products import ProductsWriter
    set_graceful(True)
    try:
        with ProductsWriter(output, source=str(Path(recording).resolve()), chain=spec.text,
                            live=True) as out:
            st = follow_chain(r, spec, out, idle_s=idle_s, log=warn)
    finally:
        set_graceful(False)
    if stats is not None:
        stats.append(st)
    return len(st.done)


def latency_line(st: Any) -> str:
    """One line: why a followed run ended and its block latencies (median, 95 %, max)."""
    import numpy as np
    lat = st.latencies()
    if lat.size == 0:
        return f"followed until {st.reason}; no block"
    q = np.percentile(lat, [50, 95])
    return (f"followed until {st.reason}; latency from a block's last sample to its products "
            f"on disk: median {q[0]:.3f} s, 95 % {q[1]:.3f} s, max {lat.max():.3f} s "
            f"({lat.size} blocks)")


# -- import -----------------------------------------------------------------------------------
def start_time_from_names(paths: Sequence[str]) -> str | None:
    """ISO-8601 start time from a file name holding ``YYYYMMDDTHHMMSSZ``, else None."""
    m = re.search(r"(\d{4})(\d{2})(\d{2})T(\d{2})(\d{2})(\d{2})Z", Path(paths[0]).name)
    if not m:
        return None
    y, mo, d, h, mi, s = m.groups()
    return f"{y}-{mo}-{d}T{h}:{mi}:{s}Z"


def import_wavs(wavs: Sequence[str], output: str, positions: Any = None,
                scale: float | None = None, sound_speed: float = 1500.0,
                start_time: str | None = None, warn: Echo = _stderr,
                inputs: Sequence[str] = ()) -> dict[str, Any]:
    """Turn WAV field recordings into one recording file.

    Parameters
    ----------
    wavs : list of str
        One multichannel WAV or one mono WAV per hydrophone (channels in the natural order of
        the names, hyd2 before hyd10, with a notice when that is not the order given; an
        ambiguous order is refused: :func:`arrayproc.io.wav.channel_order`).
    output : str
        Recording HDF5 file to write.
    positions : (n, 3) array, optional
        Element positions, m.
    scale : float, optional
        Pa per full scale (finite, non-zero); default: samples stored in full-scale units.
    sound_speed : float
        m/s, finite and > 0.
    start_time : str, optional
        ISO-8601 UTC start; default from the first file's name when it holds one.
    warn : callable
        Where warnings go (unequal lengths, truncated data).
    inputs : list of str
        Further input files (e.g. the geometry file) the output must not replace.

    Returns
    -------
    dict
        ``fs`` (Hz), ``n_channels``, ``n_samples``, ``format``, ``cut``.
    """
    check_output(output, [*wavs, *inputs])
    if scale is not None and not (_finite(scale) and scale != 0):
        raise FormatError(f"--scale must be a finite non-zero number of Pa per full scale, "
                          f"got {scale:g}")
    if not (_finite(sound_speed) and sound_speed > 0):
        raise FormatError(f"--sound-speed must be a finite number > 0 m/s, got {sound_speed:g}")
    from arrayproc.io.wav import import_wavs as _import
    return _import(wavs, output, positions=positions, scale=scale, sound_speed=sound_speed,
                   start_time=start_time or start_time_from_names(wavs), warn=warn)


# -- simulate ---------------------------------------------------------------------------------
def simulate(scenario: str, output: str, seed: int | None = None,
             duration: float | None = None, progress: bool = False,
             warn: Echo = _stderr) -> Path:
    """Simulate a recording from a scenario TOML.

    Parameters
    ----------
    scenario : str
        Scenario TOML file.
    output : str
        Recording HDF5 file to write.
    seed : int, optional
        Overrides the scenario's seed (0 <= seed < 2**64).
    duration : float, optional
        Shortens the scenario, s (finite, > 0).
    progress : bool
        Progress bar on stderr, in seconds of audio.
    warn : callable
        Where warnings go.

    Returns
    -------
    Path
        The written file.
    """
    check_output(output, [scenario])
    if seed is not None and not 0 <= seed < 2**64:
        raise ConfigError(f"--seed must be in 0..2**64-1, got {seed}")
    if duration is not None and not (_finite(duration) and duration > 0):
        raise ConfigError(f"--duration must be a finite number > 0 s, got {duration:g}")
    from arrayproc.app.progress import audio_bar
    from arrayproc.sim.run import simulate_file
    bar = audio_bar(progress, "simulate")
    try:
        return simulate_file(scenario, output, seed=seed, duration=duration, progress=bar,
                             warn=warn)
    finally:
        if bar is not None:
            bar.close()


# -- plot -------------------------------------------------------------------------------------
PLOT_PRIORITY = ("tracks", "tma", "btr", "lofar", "contacts", "bearings")


def default_plot_kind(path: str) -> str:
    """The plot kind for a products file: the first of tracks, tma, btr, lofar, contacts,
    bearings."""
    from arrayproc.io.products import product_kinds
    kinds = product_kinds(path)
    for k in PLOT_PRIORITY:
        if k in kinds:
            return "track" if k == "tracks" else k
    raise ArrayprocError(f"{path}: no plottable product (give --kind)")


def plot(file: str, output: str, kind: str | None = None, beam: float | None = None,
         range_db: float = 20.0, truth: bool = True) -> str:
    """Plot a products or tracks file into an image whose format the extension names.

    Parameters
    ----------
    file : str
        Products or tracks HDF5 file.
    output : str
        Image file; its extension (``.png``, ``.pdf``, ``.svg``, …) chooses the format.
    kind : str, optional
        btr, lofar, track, … (default: see :func:`default_plot_kind`).
    beam : float, optional
        Cone angle (deg) for LOFAR.
    range_db : float
        Displayed dynamic range, dB (finite, > 0).
    truth : bool
        Overlay the truth when the file knows it.

    Returns
    -------
    str
        The kind plotted.
    """
    check_output(output, [file])
    if not (_finite(range_db) and range_db > 0):
        raise ArrayprocError(f"--range-db must be a finite number > 0 dB, got {range_db:g}")
    if beam is not None and not _finite(beam):
        raise ArrayprocError(f"--beam must be a finite cone angle in deg, got {beam:g}")
    from arrayproc.io.atomic import commit, discard, temporary_sibling
    fmt = _image_format(output)
    from arrayproc.io.recording import open_h5
    open_h5(file, "products file").close()
    kind = kind or default_plot_kind(file)
    check_plot_input(file, kind)
    options: dict[str, Any] = {"range_db": range_db}
    if beam is not None:
        options["beam"] = beam
    if not truth:
        options["truth"] = False
    from arrayproc.plots import plot_file
    tmp = temporary_sibling(output).with_suffix("." + fmt)
    try:
        plot_file(file, str(tmp), kind, **options)
        commit(tmp, output)
    except BaseException:
        discard(tmp)
        raise
    return kind


#: What each plot reads: the product kind, its columns with their number of dimensions, and
#: the axes that label dimension 1 (one of them) and dimension 2 of the main column.
PLOT_INPUTS: dict[str, tuple[str, dict[str, int], tuple[str, ...], str | None]] = {
    "btr": ("btr", {"time": 1, "power_db": 2}, ("cone_deg", "bearing_deg"), None),
    "lofar": ("lofar", {"time": 1, "power_db": 3}, ("cone_deg", "bearing_deg"), "freq"),
    "track": ("tracks", {"time": 1, "x": 1, "y": 1}, (), None),
}

#: What the bearings tracker reads from its products file (same form as PLOT_INPUTS).
TRACK_INPUT = ("bearings", {"time": 1, "cone_deg": 1, "bearing_port_deg": 1,
                            "bearing_stbd_deg": 1}, (), None)


def check_plot_input(path: str, kind: str) -> None:
    """Refuse a products file whose groups cannot make the ``kind`` plot (FormatError naming
    the group and column): missing or non-numeric columns, wrong dimensions, no rows, axes
    that do not match the data. Only shapes and types are read."""
    if kind not in PLOT_INPUTS:
        return
    check_product_input(path, kind, PLOT_INPUTS[kind])


def check_product_input(path: str, use: str, spec: tuple, empty_ok: bool = False) -> None:
    """Refuse a products file whose groups of ``spec``'s kind lack a numeric column of the
    declared dimensions, have no rows (unless ``empty_ok``: a reader such as the tracker for
    which no rows is a valid input), or axes that do not match (see :data:`PLOT_INPUTS`);
    ``use`` names the reader in the message."""
    import h5py

    from arrayproc.io.products import FORMAT
    from arrayproc.io.recording import _attr_str, get_object, open_h5
    kind = use
    pkind, cols, axes, axis2 = spec
    with open_h5(path, "products file") as f:
        if _attr_str(f.attrs.get("format", "")) != FORMAT:
            raise FormatError(f"{path}: not an arrayproc products file")
        groups = [n for n in f if isinstance(get_object(f, Path(path), n), h5py.Group)
                  and _attr_str(f[n].attrs.get("kind", "")) == pkind]
        if not groups:
            raise FormatError(f"{path}: no {pkind} group for {kind}")
        for name in groups:
            g = f[name]
            where = f"{path}: group {name!r} (kind {pkind!r})"
            rows = set()
            if empty_ok and not any(isinstance(g.get(c), h5py.Dataset) for c in cols):
                continue  # no column at all: an older file's empty group, read as empty
            for col, ndim in cols.items():
                d = get_object(f, Path(path), f"{name}/{col}")
                if not isinstance(d, h5py.Dataset):
                    raise FormatError(f"{where}: no column {col!r}")
                if d.dtype.kind not in "fiu":
                    raise FormatError(f"{where}: column {col!r} must be numeric, has type "
                                      f"{d.dtype}")
                if d.ndim != ndim:
                    raise FormatError(f"{where}: column {col!r} must have {ndim} dimension(s), "
                                      f"has shape {d.shape}")
                rows.add(d.shape[0])
            if len(rows) != 1:
                raise FormatError(f"{where}: columns have different numbers of rows {rows}")
            if rows == {0} and not empty_ok:
                raise FormatError(f"{where}: has 0 rows; nothing to plot")
            main = next(c for c, n in cols.items() if n >= 2) if any(
                n >= 2 for n in cols.values()) else None
            if main is None:
                continue
            shape = g[main].shape
            found = [a for a in axes if isinstance(g.get(a), h5py.Dataset)]
            if axes and not found:
                raise FormatError(f"{where}: no beam axis ({' or '.join(axes)})")
            if found and g[found[0]].shape[0] != shape[1]:
                raise FormatError(f"{where}: axis {found[0]!r} has {g[found[0]].shape[0]} "
                                  f"values but {main!r} has {shape[1]} beams")
            if axis2 is not None:
                a2 = g.get(axis2)
                if not isinstance(a2, h5py.Dataset) or a2.shape[0] != shape[2]:
                    raise FormatError(f"{where}: axis {axis2!r} must have {shape[2]} values")


def _image_format(output: str) -> str:
    """The image format the output's extension names, or ArrayprocError."""
    import matplotlib
    matplotlib.use("Agg")
    from matplotlib.figure import Figure
    known = Figure().canvas.get_supported_filetypes()
    ext = Path(output).suffix.lower().lstrip(".")
    if ext not in known:
        raise ArrayprocError(f"{output}: plot output needs an image extension "
                             f"({', '.join('.' + k for k in sorted(known))})")
    return ext


# -- track ------------------------------------------------------------------------------------
def track(products: str, config: str, output: str, progress: bool = False) -> None:
    """Track targets from a products file's bearings into a tracks file.

    Parameters
    ----------
    products : str
        Products HDF5 file with a bearings group.
    config : str
        Tracker TOML file.
    output : str
        Tracks HDF5 file to write.
    progress : bool
        Progress messages on stderr.
    """
    inputs = [products, config]
    rec = _products_source(products)
    if rec is not None:
        inputs.append(rec)  # the recording whose navigation the tracker reads
    check_output(output, inputs)
    from arrayproc.track.runner import load_tracker_config
    cfg = load_tracker_config(config)  # configuration errors first, before the products are read
    if cfg.get("mode") != "multi" or cfg["multi"]["measurements"] == "bearings":
        check_product_input(products, "the tracker", TRACK_INPUT, empty_ok=True)
    from arrayproc.track.runner import run_tracker
    run_tracker(products, config, output, progress=progress, cfg=cfg)


def _products_source(products: str) -> str | None:
    """The recording a products file names in its ``source`` attribute (if it exists)."""
    try:
        from arrayproc.io.products import products_source
        src = products_source(products)
    except ArrayprocError:
        return None
    if not src:
        return None
    for p in (Path(src), Path(products).parent / src):  # as the tracker resolves it
        if p.exists():
            return str(p)
    return None


# -- tma --------------------------------------------------------------------------------------
def tma(products: str, config: str, output: str, progress: bool = False) -> None:
    """Batch maximum-likelihood TMA with its CRLB (thesis 3.3; compact-array paper eqs. 1-5).

    Parameters
    ----------
    products : str
        Products HDF5 file with a bearings or delays group.
    config : str
        TMA TOML file (``[tma] method = "bearings" | "delays" | "compact"``, …).
    output : str
        Products HDF5 file to write (one ``tma`` group).
    progress : bool
        One line per solution on stderr.
    """
    inputs = [products, config]
    rec = _products_source(products)
    if rec is not None:
        inputs.append(rec)  # the recording whose navigation and geometry are read
    check_output(output, inputs)
    from arrayproc.track.batch.run import run_tma
    run_tma(products, config, output, progress=progress)


# -- export -----------------------------------------------------------------------------------
def export(files: Sequence[str], to: str, output: str,
           origin: tuple[float, float] = (0.0, 0.0)) -> int:
    """Write products or tracks files in an exchange format (Raven selection tables, Debrief REP).

    Parameters
    ----------
    files : sequence of str
        ``raven``: products files with detections or bearings, consecutive recordings in time
        order; ``rep``: one tracks file or products file with bearings.
    to : {"raven", "rep"}
        Raven selection table or Debrief replay file.
    output : str
        Text file to write.
    origin : (float, float)
        ``rep``: latitude and longitude (deg) of the world frame's origin.

    Returns
    -------
    int
        Selections (raven) or lines (rep) written.
    """
    from arrayproc.io import exports
    from arrayproc.io.atomic import commit, discard, temporary_sibling
    if to not in ("raven", "rep"):
        raise ConfigError(f"export: --to must be raven or rep, not {to!r}")
    if to == "rep" and len(files) != 1:
        raise ConfigError("export: --to rep takes one file")
    check_output(output, list(files))
    tmp = temporary_sibling(output)
    try:
        n = (exports.write_raven(list(files), str(tmp)) if to == "raven"
             else exports.write_rep(files[0], str(tmp), origin=origin))
        commit(tmp, output)
    except BaseException:
        discard(tmp)
        raise
    return n


# -- command line -----------------------------------------------------------------------------
def add_geometry_options(p: argparse.ArgumentParser) -> None:
    """``--line N SPACING`` / ``--geometry FILE`` (mutually exclusive)."""
    g = p.add_mutually_exclusive_group()
    g.add_argument("--line", nargs=2, type=float, metavar=("N", "SPACING"),
                   help="uniform line array of N elements SPACING m apart")
    g.add_argument("--geometry", metavar="FILE",
                   help="element positions: CSV with x,y,z columns or acoular XML")
    p.add_argument("--z-up", action="store_true",
                   help="the geometry file's z axis points up (arrayproc's points down)")


def _geometry_of(args: argparse.Namespace):
    return geometry(getattr(args, "line", None), getattr(args, "geometry", None),
                    z_up=getattr(args, "z_up", False))


def _geometry_inputs(args: argparse.Namespace) -> list[str]:
    return [args.geometry] if getattr(args, "geometry", None) else []


def _run_info(args: argparse.Namespace) -> int:
    info(args.file, positions=_geometry_of(args))
    return 0


def _run_process(args: argparse.Namespace) -> int:
    from arrayproc.app.resources import parse_bytes
    done = Summary.of(args)
    check_output(args.output, [args.recording, args.chain, *_geometry_inputs(args)])
    limit = parse_bytes(args.max_memory) if args.max_memory is not None else None
    if args.idle is not None and not args.follow:
        raise ConfigError("--idle needs --follow")
    stats: list = []
    n = process(args.recording, args.chain, args.output, positions=_geometry_of(args),
                nan=args.nan, progress=bar_wanted(args) and not args.follow,
                max_memory=limit, follow=args.follow,
                idle_s=10.0 if args.idle is None else args.idle, stats=stats)
    if stats and not args.quiet:
        print(latency_line(stats[0]))
    done(args.output, f"{products_what(args.output)}, {n} block{'s' * (n != 1)}",
         audio_seconds(args.recording))
    return 0


def _run_import(args: argparse.Namespace) -> int:
    done = Summary.of(args)
    check_output(args.output, [*args.wav, *_geometry_inputs(args)])
    r = import_wavs(args.wav, args.output, positions=_geometry_of(args), scale=args.scale,
                    sound_speed=args.sound_speed, start_time=args.start_time,
                    inputs=_geometry_inputs(args))
    done(args.output, f"{recording_what(args.output)}, {r['format']}",
         audio_seconds(args.output))
    return 0


def _run_simulate(args: argparse.Namespace) -> int:
    done = Summary.of(args)
    simulate(args.scenario, args.output, seed=args.seed, duration=args.duration,
             progress=bar_wanted(args))
    done(args.output, recording_what(args.output), audio_seconds(args.output))
    return 0


def _run_plot(args: argparse.Namespace) -> int:
    kind = plot(args.file, args.output, kind=args.kind, beam=args.beam,
                range_db=args.range_db, truth=not args.no_truth)
    print(f"{args.output}: {kind} plot written")
    return 0


def _run_track(args: argparse.Namespace) -> int:
    done = Summary.of(args)
    track(args.products, args.config, args.output, progress=bar_wanted(args))
    done(args.output, _tracks_summary(args.output), audio_seconds(args.output))
    return 0


def _tracks_summary(path: str) -> str:
    """``N tracks, M points`` (``no tracks (…): empty tracks table`` for an empty result), read
    from the tracks file just written, for the summary line."""
    import numpy as np

    from arrayproc.io.products import read_products
    from arrayproc.io.schema import groups_of_kind
    prod = read_products(path)
    ids = [np.asarray(prod[n]["track_id"]).reshape(-1) for n in groups_of_kind(prod, "tracks")
           if "track_id" in prod[n]]
    n_pts = sum(i.size for i in ids)
    if n_pts == 0:
        return "no tracks (no measurements to track): empty tracks table"
    n_tr = sum(np.unique(i).size for i in ids)
    return f"{n_tr} track{'s' * (n_tr != 1)}, {n_pts} points"


def _run_tma(args: argparse.Namespace) -> int:
    done = Summary.of(args)
    tma(args.products, args.config, args.output, progress=bar_wanted(args))
    done(args.output, products_what(args.output), audio_seconds(args.output))
    return 0


def _run_export(args: argparse.Namespace) -> int:
    done = Summary.of(args)
    n = export(args.files, args.to, args.output, origin=tuple(args.origin))
    audio = [audio_seconds(f) for f in args.files]
    done(args.output, f"{n} {'selections' if args.to == 'raven' else 'lines'}",
         sum(audio) if all(a is not None for a in audio) else None)
    return 0


def _run_data_dir(args: argparse.Namespace) -> int:
    from arrayproc.data import data_path
    print(data_path())
    return 0


QUIET_HELP = "no summary line at the end"


def add_parser(sub: Any) -> None:
    """Register this module's sub-commands (info, process, import, simulate, plot, track, tma,
    export, data-dir) on the command line's sub-parsers (the demo registers itself, app/demo.py)."""
    s = sub.add_parser("info", help="describe a recording or products file")
    s.add_argument("file")
    add_geometry_options(s)
    s.add_argument("--nan", choices=("error", "zero"), default="error", help=argparse.SUPPRESS)
    s.set_defaults(func=_run_info)

    s = sub.add_parser("process", help="run a processing chain over a recording")
    s.add_argument("recording")
    s.add_argument("-c", "--chain", required=True, help="chain TOML file")
    s.add_argument("-o", "--output", required=True, help="products HDF5 file to write")
    s.add_argument("--no-progress", action="store_true", help="no progress bar")
    s.add_argument("-q", "--quiet", action="store_true", help=QUIET_HELP)
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

    s = sub.add_parser("import", help="turn WAV field recordings into a recording file")
    s.add_argument("wav", nargs="+", help="one multichannel WAV or one mono WAV per hydrophone "
                   "(channels in the natural order of the names: hyd2 before hyd10)")
    s.add_argument("-o", "--output", required=True)
    s.add_argument("--scale", type=float, default=None,
                   help="pascals per full scale (default: store full-scale units)")
    s.add_argument("--sound-speed", type=float, default=1500.0, help="m/s (default 1500)")
    s.add_argument("--start-time", default=None, help="ISO-8601 UTC start (default: from the "
                   "file name when it holds one, e.g. 20190920T163858Z)")
    s.add_argument("-q", "--quiet", action="store_true", help=QUIET_HELP)
    add_geometry_options(s)
    s.set_defaults(func=_run_import)

    s = sub.add_parser("simulate", help="simulate a recording from a scenario TOML")
    s.add_argument("scenario")
    s.add_argument("-o", "--output", required=True)
    s.add_argument("--seed", type=int, default=None, help="overrides the scenario's seed")
    s.add_argument("--duration", type=float, default=None, help="shorten the scenario (s)")
    s.add_argument("--no-progress", action="store_true")
    s.add_argument("-q", "--quiet", action="store_true", help=QUIET_HELP)
    s.set_defaults(func=_run_simulate)

    s = sub.add_parser("plot", help="plot a products or tracks file")
    s.add_argument("file")
    s.add_argument("--kind", default=None, help="btr, lofar, track, … (default: the first found)")
    s.add_argument("--beam", type=float, default=None, help="cone angle (deg) for LOFAR")
    s.add_argument("--range-db", type=float, default=20.0, help="displayed dynamic range, dB")
    s.add_argument("--no-truth", action="store_true", help="no truth overlay")
    s.add_argument("-o", "--output", required=True,
                   help="image file; the extension names the format (.png, .pdf, .svg, …)")
    s.set_defaults(func=_run_plot)

    s = sub.add_parser("track", help="track targets from a products file's measurements")
    s.add_argument("products")
    s.add_argument("-c", "--config", required=True, help="tracker TOML file")
    s.add_argument("-o", "--output", required=True)
    s.add_argument("--no-progress", action="store_true")
    s.add_argument("-q", "--quiet", action="store_true", help=QUIET_HELP)
    s.set_defaults(func=_run_track)

    s = sub.add_parser("tma", help="batch ML target motion analysis (bearings, delays or "
                       "compact) with Cramér-Rao bounds")
    s.add_argument("products")
    s.add_argument("-c", "--config", required=True, help="TMA TOML file")
    s.add_argument("-o", "--output", required=True, help="products HDF5 file to write")
    s.add_argument("--no-progress", action="store_true")
    s.add_argument("-q", "--quiet", action="store_true", help=QUIET_HELP)
    s.set_defaults(func=_run_tma)

    s = sub.add_parser("export", help="write Raven selection tables or Debrief REP files")
    s.add_argument("files", nargs="+", help="products files (raven: in time order) or one "
                   "tracks file (rep)")
    s.add_argument("--to", required=True, choices=("raven", "rep"))
    s.add_argument("-o", "--output", required=True, help="text file to write")
    s.add_argument("--origin", type=float, nargs=2, default=(0.0, 0.0),
                   metavar=("LAT", "LON"), help="rep: latitude/longitude of x = y = 0 (deg)")
    s.add_argument("-q", "--quiet", action="store_true", help=QUIET_HELP)
    s.set_defaults(func=_run_export)

    s = sub.add_parser("data-dir", help="print the folder of the bundled chains, scenarios, "
                       "trackers and TMA configurations")
    s.set_defaults(func=_run_data_dir)

