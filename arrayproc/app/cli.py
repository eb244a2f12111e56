"""The ``arrayproc`` command line (DESIGN section 6).

Errors a user can cause print one line ``arrayproc: error: …`` and exit with status 2; outputs
are written to a temporary file and renamed, so a failed run leaves nothing behind.
"""

from __future__ import annotations

import argparse
import os
import re
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from arrayproc import __version__
from arrayproc.errors import ArrayprocError, FormatError


def warn(msg: str) -> None:
    print(f"arrayproc: warning: {msg}", file=sys.stderr)


def _show_progress(args: argparse.Namespace) -> bool:
    return not getattr(args, "no_progress", False) and sys.stderr.isatty()


def _geometry(args: argparse.Namespace) -> np.ndarray | None:
    from arrayproc.io.geometry import line_array, read_geometry
    if getattr(args, "line", None) is not None:
        n, spacing = args.line
        if n != int(n):
            raise FormatError("--line N SPACING: N must be a whole number")
        return line_array(int(n), spacing)
    if getattr(args, "geometry", None):
        return read_geometry(args.geometry)
    return None


def _open_recording(args: argparse.Namespace, path: str | None = None):
    from arrayproc.io.recording import Recording
    return Recording(path or args.recording, positions=_geometry(args), nan=args.nan)


# -- commands -------------------------------------------------------------------------------
def cmd_info(args: argparse.Namespace) -> int:
    from arrayproc.io.products import is_products
    from arrayproc.io.recording import open_h5
    path = Path(args.file)
    open_h5(path).close()  # uniform errors for missing / non-HDF5 / truncated files
    if is_products(path):
        from arrayproc.io.products import read_products
        groups = read_products(path)
        root = groups.pop("/")
        print(f"{path}: arrayproc products, format version {root.get('format_version')}, "
              f"complete={bool(root.get('complete'))}")
        print(f"  source: {root.get('source', '')}")
        for name, g in groups.items():
            cols = [k for k, v in g.items() if isinstance(v, np.ndarray)]
            rows = max((g[k].shape[0] for k in cols if g[k].ndim), default=0)
            print(f"  {name}: kind={g['kind']} rows={rows} datasets={', '.join(cols)}")
        return 0
    from arrayproc.io.geometry import aperture, geometry_kind
    with _open_recording(args, args.file) as r:
        layout = (f"arrayproc recording, format version {r.format_version}"
                  if r.layout == "arrayproc" else "acoular layout (no format attributes: "
                  "defaults applied)")
        print(f"{path}: {layout}")
        print(f"  channels: {r.n_channels} active of {r.n_channels_file}")
        print(f"  sample rate: {r.fs:g} Hz, samples: {r.n_samples}, duration: "
              f"{r.duration:.3f} s, units: {r.units}")
        print(f"  sound speed: {r.sound_speed:g} m/s, start: {r.start_time or 'unknown'}")
        print(f"  geometry: {geometry_kind(r.positions)} ({r.geometry_source}), aperture "
              f"{aperture(r.positions):.3f} m")
        nav = r.nav
        if nav.time.size > 1:
            lo, hi = nav.position.min(0), nav.position.max(0)
            print(f"  nav: {nav.time.size} fixes over {nav.time[0]:.1f}-{nav.time[-1]:.1f} s, "
                  f"x {lo[0]:.1f}..{hi[0]:.1f} m, y {lo[1]:.1f}..{hi[1]:.1f} m")
        else:
            print(f"  nav: static at ({nav.position[0, 0]:.1f}, {nav.position[0, 1]:.1f}) m, "
                  f"heading {nav.heading[0]:.1f} deg")
        if r.has("truth"):
            t = r.read_group("truth")
            n_src = len([k for k in t.get("sources", {}) if k != "attrs"])
            print(f"  truth: {n_src} source(s)" + (", pings" if "pings" in t else ""))
    return 0


def cmd_process(args: argparse.Namespace) -> int:
    from arrayproc.app.api import load_chain, run_chain
    from arrayproc.io.products import ProductsWriter
    spec = load_chain(args.chain)  # validated before any data is read
    with _open_recording(args) as r:
        with ProductsWriter(args.output, source=str(Path(args.recording).resolve()),
                            chain=spec.text) as out:
            n = run_chain(r, spec, out, progress=_show_progress(args), log=warn)
        if r.n_nonfinite:
            warn(f"{args.recording}: {r.n_nonfinite} NaN/Inf samples replaced by zeros")
    if not args.quiet:
        print(f"{args.output}: {n} blocks processed")
    return 0


def _start_time_from_names(paths: Sequence[str]) -> str | None:
    m = re.search(r"(\d{4})(\d{2})(\d{2})T(\d{2})(\d{2})(\d{2})Z", Path(paths[0]).name)
    if not m:
        return None
    y, mo, d, h, mi, s = m.groups()
    return f"{y}-{mo}-{d}T{h}:{mi}:{s}Z"


def cmd_import(args: argparse.Namespace) -> int:
    from arrayproc.io.wav import import_wavs
    pos = _geometry(args)
    info = import_wavs(args.wav, args.output, positions=pos, scale=args.scale,
                       sound_speed=args.sound_speed,
                       start_time=args.start_time or _start_time_from_names(args.wav), warn=warn)
    if not args.quiet:
        print(f"{args.output}: {info['n_channels']} channels, {info['n_samples']} samples at "
              f"{info['fs']} Hz ({info['format']})")
    return 0


# -- parser ---------------------------------------------------------------------------------
def _add_geometry(p: argparse.ArgumentParser) -> None:
    g = p.add_mutually_exclusive_group()
    g.add_argument("--line", nargs=2, type=float, metavar=("N", "SPACING"),
                   help="uniform line array of N elements SPACING m apart")
    g.add_argument("--geometry", metavar="FILE",
                   help="element positions: CSV with x,y,z columns or acoular XML")


def _add_nan(p: argparse.ArgumentParser) -> None:
    p.add_argument("--nan", choices=("error", "zero"), default="error",
                   help="NaN/Inf samples: stop with an error (default) or zero them")


class _Parser(argparse.ArgumentParser):
    """Usage errors as one line, exit status 2."""

    def error(self, message: str) -> None:  # type: ignore[override]
        print(f"{self.prog}: error: {message} (see --help)", file=sys.stderr)
        raise SystemExit(2)


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="arrayproc", description=__doc__.splitlines()[0])
    p.add_argument("--version", action="version", version=f"arrayproc {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True

    s = sub.add_parser("info", help="describe a recording or products file")
    s.add_argument("file")
    _add_geometry(s)
    _add_nan(s)
    s.set_defaults(func=cmd_info)

    s = sub.add_parser("process", help="run a processing chain over a recording")
    s.add_argument("recording")
    s.add_argument("-c", "--chain", required=True, help="chain TOML file")
    s.add_argument("-o", "--output", required=True, help="products HDF5 file to write")
    s.add_argument("--no-progress", action="store_true", help="no progress bar")
    s.add_argument("-q", "--quiet", action="store_true")
    _add_geometry(s)
    _add_nan(s)
    s.set_defaults(func=cmd_process)

    s = sub.add_parser("import", help="turn WAV field recordings into a recording file")
    s.add_argument("wav", nargs="+", help="one multichannel WAV or one mono WAV per hydrophone")
    s.add_argument("-o", "--output", required=True)
    s.add_argument("--scale", type=float, default=None,
                   help="pascals per full scale (default: store full-scale units)")
    s.add_argument("--sound-speed", type=float, default=1500.0, help="m/s (default 1500)")
    s.add_argument("--start-time", default=None, help="ISO-8601 UTC start (default: from the "
                   "file name when it holds one, e.g. 20190920T163858Z)")
    s.add_argument("-q", "--quiet", action="store_true")
    _add_geometry(s)
    s.set_defaults(func=cmd_import)

    _add_late_commands(sub)
    return p


def _add_late_commands(sub) -> None:
    """Commands whose implementation lives in other modules (simulator, plots, tracking)."""
    from arrayproc.app import commands
    commands.add_to(sub)


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except ArrayprocError as e:
        print(f"arrayproc: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("arrayproc: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # e.g. `arrayproc info f.h5 | head`: stop quietly
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 1
    except MemoryError:
        print("arrayproc: error: out of memory (try a smaller block size)", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
