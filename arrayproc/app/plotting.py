"""``arrayproc plot``: a products or tracks file drawn into an image file, written atomically.

The plot functions themselves (:mod:`arrayproc.plots`) draw on a matplotlib ``Axes`` and return
the ``Figure``; this layer picks the kind, checks the input's shapes
(:mod:`arrayproc.app.inputs`), selects the Agg backend (it only writes files) and names the
format from the extension.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from arrayproc.app.inputs import check_plot_input
from arrayproc.app.options import finite
from arrayproc.errors import ArrayprocError
from arrayproc.io.atomic import check_output

PLOT_PRIORITY = ("tracks", "tma", "btr", "lofar", "contacts", "bearings")
#: Plots of a recording's samples or array: they take a recording, or a products file whose
#: recording they read.
RECORDING_PLOTS = ("spectrogram", "geometry")


def default_plot_kind(path: str) -> str:
    """The plot kind for a products file: the first of tracks, tma, btr, lofar, contacts,
    bearings (a recording needs ``--kind spectrogram`` or ``geometry``)."""
    from arrayproc.io.products import product_kinds
    kinds = product_kinds(path)
    for k in PLOT_PRIORITY:
        if k in kinds:
            return "track" if k == "tracks" else k
    raise ArrayprocError(f"{path}: no plottable product (give --kind)")


def plot(file: str, output: str, kind: str | None = None, beam: float | None = None,
         range_db: float = 20.0, truth: bool = True, t0: float | None = None,
         t1: float | None = None, fmin: float | None = None, fmax: float | None = None,
         channel: int | None = None) -> str:
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
    t0, t1 : float, optional
        Time window shown, s since the recording's start, on every time axis.
    fmin, fmax : float, optional
        Band shown, Hz, on every frequency axis.
    channel : int, optional
        The channel of a spectrogram (default 0).

    Returns
    -------
    str
        The kind plotted.
    """
    check_output(output, [file])
    if not (finite(range_db) and range_db > 0):
        raise ArrayprocError(f"--range-db must be a finite number > 0 dB, got {range_db:g}")
    if beam is not None and not finite(beam):
        raise ArrayprocError(f"--beam must be a finite cone angle in deg, got {beam:g}")
    from arrayproc.io.atomic import atomic_path
    from arrayproc.plots.limits import Limits
    limits = Limits(t0, t1, fmin, fmax)
    fmt = _image_format(output)
    from arrayproc.io.h5 import open_h5
    open_h5(file, "recording or products file" if kind in RECORDING_PLOTS
            else "products file").close()
    kind = kind or default_plot_kind(file)
    check_plot_input(file, kind)
    options: dict[str, Any] = {"range_db": range_db}
    if beam is not None:
        options["beam"] = beam
    if not truth:
        options["truth"] = False
    if channel is not None:
        if kind not in ("spectrogram", "detections"):
            raise ArrayprocError(f"--channel is for the spectrogram and detections plots, "
                                 f"not {kind}")
        options["channel"] = int(channel)
    from arrayproc.plots import plot_file
    with atomic_path(output, suffix="." + fmt) as tmp:
        plot_file(file, str(tmp), kind, limits=limits, **options)
    return kind


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
