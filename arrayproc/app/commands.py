"""Command-line commands that live outside the I/O core: simulate, plot, track, demo."""

from __future__ import annotations

import argparse
import sys


def _progress(args: argparse.Namespace) -> bool:
    return not getattr(args, "no_progress", False) and sys.stderr.isatty()


def cmd_simulate(args: argparse.Namespace) -> int:
    from arrayproc.app.cli import warn
    from arrayproc.sim.run import simulate_file
    simulate_file(args.scenario, args.output, seed=args.seed, duration=args.duration,
                  progress=_progress(args), warn=warn)
    if not args.quiet:
        print(f"{args.output}: written")
    return 0


def cmd_plot(args: argparse.Namespace) -> int:
    from arrayproc.errors import ArrayprocError
    from arrayproc.io.atomic import commit, discard, temporary_sibling
    from arrayproc.plots import plot_file
    kind = args.kind or _default_kind(args.file)
    options = {"range_db": args.range_db}
    if args.beam is not None:
        options["beam"] = args.beam
    if args.no_truth:
        options["truth"] = False
    tmp = temporary_sibling(args.output).with_suffix(".png")
    try:
        plot_file(args.file, str(tmp), kind, **options)
        commit(tmp, args.output)
    except BaseException:
        discard(tmp)
        raise
    if not tmp.parent.exists():
        raise ArrayprocError(f"{args.output}: directory vanished")
    print(f"{args.output}: {kind} plot written")
    return 0


def _default_kind(path: str) -> str:
    from arrayproc.io.products import read_products
    kinds = [g["kind"] for n, g in read_products(path).items() if n != "/"]
    for k in ("tracks", "btr", "lofar", "contacts", "bearings"):
        if k in kinds:
            return "track" if k == "tracks" else k
    from arrayproc.errors import ArrayprocError
    raise ArrayprocError(f"{path}: no plottable product (give --kind)")


def cmd_track(args: argparse.Namespace) -> int:
    from arrayproc.track.runner import run_tracker
    run_tracker(args.products, args.config, args.output, progress=_progress(args))
    print(f"{args.output}: tracks written")
    return 0


def cmd_demo(args: argparse.Namespace) -> int:
    from arrayproc.app.demo import run_demo
    run_demo(args.output, progress=_progress(args))
    return 0


def add_to(sub) -> None:
    s = sub.add_parser("simulate", help="simulate a recording from a scenario TOML")
    s.add_argument("scenario")
    s.add_argument("-o", "--output", required=True)
    s.add_argument("--seed", type=int, default=None, help="overrides the scenario's seed")
    s.add_argument("--duration", type=float, default=None, help="shorten the scenario (s)")
    s.add_argument("--no-progress", action="store_true")
    s.add_argument("-q", "--quiet", action="store_true")
    s.set_defaults(func=cmd_simulate)

    s = sub.add_parser("plot", help="plot a products or tracks file")
    s.add_argument("file")
    s.add_argument("--kind", default=None, help="btr, lofar, track, … (default: the first found)")
    s.add_argument("--beam", type=float, default=None, help="cone angle (deg) for LOFAR")
    s.add_argument("--range-db", type=float, default=20.0, help="displayed dynamic range, dB")
    s.add_argument("--no-truth", action="store_true", help="no truth overlay")
    s.add_argument("-o", "--output", required=True, help="PNG file")
    s.set_defaults(func=cmd_plot)

    s = sub.add_parser("track", help="track targets from a products file's measurements")
    s.add_argument("products")
    s.add_argument("-c", "--config", required=True, help="tracker TOML file")
    s.add_argument("-o", "--output", required=True)
    s.add_argument("--no-progress", action="store_true")
    s.set_defaults(func=cmd_track)

    s = sub.add_parser("demo", help="simulate, process, track and plot the bundled example")
    s.add_argument("-o", "--output", default="demo_out", help="output directory")
    s.add_argument("--no-progress", action="store_true")
    s.set_defaults(func=cmd_demo)
