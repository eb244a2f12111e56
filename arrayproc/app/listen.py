"""``arrayproc listen``: the beam of one direction as a WAV file to listen to.

The beam is the time-domain delay-and-sum with fractional delays of
:mod:`arrayproc.stages.beamform.beam_audio` (the chain stage ``beam_audio`` does the same
inside a chain), over a segment of the recording, band-passed when asked and normalised to a
peak of ``--peak-dbfs``; the WAV's comment gives the scale (``1 FS = X Pa``).
"""

from __future__ import annotations

import argparse
from typing import Any

from arrayproc.app.options import (
    add_geometry_options,
    add_output,
    add_quiet,
    finite,
    geometry_inputs,
    geometry_of,
)
from arrayproc.errors import ConfigError
from arrayproc.io.atomic import check_output


def listen(recording: str, output: str, cone_deg: float | None = None,
           bearing_deg: float | None = None, elevation_deg: float = 0.0,
           band: tuple[float, float] | None = None, start_s: float = 0.0,
           duration_s: float | None = None, shading: str = "none", peak_dbfs: float = -1.0,
           positions: Any = None, inputs: tuple[str, ...] = ()) -> dict[str, Any]:
    """Write the beam of one direction of a recording as a normalised WAV file.

    Parameters
    ----------
    recording : str
        Recording file.
    output : str
        WAV file to write.
    cone_deg : float, optional
        Cone angle of the beam, deg (line arrays; only the elements' body x enters).
    bearing_deg, elevation_deg : float, optional
        Bearing relative to the array's forward axis (clockwise) and elevation (up), deg, for
        3-D arrays, instead of ``cone_deg``.
    band : (lo, hi), optional
        Band-pass of the beam, Hz.
    start_s, duration_s : float
        Segment of the recording, s (default: all of it).
    shading : str
        Array shading (:data:`arrayproc.dsp.shading.KINDS`).
    peak_dbfs : float
        Peak of the WAV, dB re full scale (≤ 0).
    positions : (n, 3) array, optional
        Element positions overriding the file's.
    inputs : tuple of str
        Further input files the output must not replace.

    Returns
    -------
    dict
        ``fs`` (Hz), ``n_samples``, ``per_fs`` (the recording's units per full scale of the
        WAV), ``units``.
    """
    from arrayproc.io.audio import write_beam_wav
    from arrayproc.io.recording import Recording
    from arrayproc.stages.beamform.beam_audio import beam_series
    check_output(output, [recording, *inputs])
    if not (finite(start_s) and start_s >= 0):
        raise ConfigError(f"--start must be a finite number >= 0 s, got {start_s:g}")
    if duration_s is not None and not (finite(duration_s) and duration_s > 0):
        raise ConfigError(f"--duration must be a finite number > 0 s, got {duration_s:g}")
    if not (finite(peak_dbfs) and peak_dbfs <= 0):
        raise ConfigError(f"--peak-dbfs must be <= 0, got {peak_dbfs:g}")
    with Recording(recording, positions=positions) as rec:
        if start_s >= rec.duration:
            raise ConfigError(f"--start {start_s:g} s is beyond the recording's end "
                              f"({rec.duration:g} s)")
        y = beam_series(rec, start_s, duration_s, cone_deg=cone_deg, bearing_deg=bearing_deg,
                        elevation_deg=elevation_deg, shading=shading,
                        band=tuple(band) if band is not None else None)
        d = (f"cone {cone_deg:g} deg" if cone_deg is not None
             else f"bearing {bearing_deg:g} deg, elevation {elevation_deg:g} deg")
        per_fs = write_beam_wav(output, y, rec.fs, peak_dbfs, rec.units, d)
        return {"fs": rec.fs, "n_samples": int(y.size), "per_fs": per_fs, "units": rec.units}


def _run_listen(args: argparse.Namespace) -> int:
    from arrayproc.app.progress import Summary
    done = Summary.of(args)
    r = listen(args.recording, args.output, cone_deg=args.cone, bearing_deg=args.bearing,
               elevation_deg=args.elevation, band=args.band, start_s=args.start,
               duration_s=args.duration, shading=args.shading, peak_dbfs=args.peak_dbfs,
               positions=geometry_of(args), inputs=tuple(geometry_inputs(args)))
    done(args.output, f"{r['n_samples'] / r['fs']:g} s at {r['fs']:g} Hz, 1 FS = "
         f"{r['per_fs']:.3g} {r['units']}", r["n_samples"] / r["fs"])
    return 0


def add_parser(sub: Any) -> None:
    """Register ``listen`` on the command line's sub-parsers."""
    from arrayproc.dsp.shading import KINDS
    s = sub.add_parser("listen", help="write the beam of one direction as a WAV file")
    s.add_argument("recording", help="recording HDF5 file")
    d = s.add_mutually_exclusive_group(required=True)
    d.add_argument("--cone", type=float, metavar="DEG",
                   help="cone angle of the beam, deg (0 forward end-fire, 90 broadside)")
    d.add_argument("--bearing", type=float, metavar="DEG",
                   help="bearing relative to the array's forward axis, clockwise, deg "
                        "(3-D arrays)")
    s.add_argument("--elevation", type=float, default=0.0, metavar="DEG",
                   help="elevation of the beam with --bearing, deg up (default 0)")
    s.add_argument("--band", type=float, nargs=2, default=None, metavar=("LO", "HI"),
                   help="band-pass of the beam, Hz")
    s.add_argument("--start", type=float, default=0.0, metavar="S",
                   help="start of the segment, s since the recording's start (default 0)")
    s.add_argument("--duration", type=float, default=None, metavar="S",
                   help="length of the segment, s (default: to the end)")
    s.add_argument("--shading", choices=KINDS, default="none", help="array shading")
    s.add_argument("--peak-dbfs", type=float, default=-1.0, metavar="DB",
                   help="peak of the WAV, dB re full scale (default -1)")
    add_output(s, "WAV file to write")
    add_quiet(s)
    add_geometry_options(s)
    s.set_defaults(func=_run_listen)
