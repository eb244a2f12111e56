"""Detections plot: a channel's spectrogram (frequency across, time running down) with the
time-frequency boxes of the ``detections`` product."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from arrayproc.plots import register_plot, write_figure
from arrayproc.plots._delay import groups_of, source_recording

#: Figure size and resolution of the detections plot.
LAYOUT = {"figsize": (8.0, 8.0), "dpi": 110}


@register_plot("detections")
def plot_detections(path: str, out_png: str, channel: int | None = None, nfft: int = 1024,
                    range_db: float = 50.0, fmax: float | None = None,
                    beam: float | None = None, truth: bool = True) -> None:
    """Draw the spectrogram of ``channel`` (default: the detections' channel) of the recording
    the products file ``path`` was made from, with each detection's box, into ``out_png``.

    Parameters
    ----------
    path : str
        Products file holding a ``detections`` group.
    out_png : str
        Output image.
    channel : int, optional
        Channel shown.
    nfft : int
        Spectrogram frame (Hann, 50 % overlap), samples.
    range_db : float
        Colour range below the 99.9th percentile, dB.
    fmax : float, optional
        Highest frequency shown, Hz (default: twice the highest detection band edge).
    beam, truth
        Options of the other plots, unused here.
    """
    found, root = groups_of(path, "detections")
    name, g = found[0]
    ch = int(channel if channel is not None else (g["channel"][0] if "channel" in g
                                                   and len(g["channel"]) else 0))
    with source_recording(root, path, "detections") as rec:
        x = rec.read()[:, ch].astype(float)
        fs = rec.fs
        units = rec.units
    write_figure(lambda ax: draw_detections(
        g, x, fs, units, ax, channel=ch, nfft=nfft, range_db=range_db, fmax=fmax,
        title=f"channel {ch} spectrogram with {{n}} detections ({name})\n{Path(path).name}"),
        out_png, LAYOUT)


def draw_detections(g: dict, x: np.ndarray, fs: float, units: str, ax: Any = None,
                    channel: int = 0, nfft: int = 1024, range_db: float = 50.0,
                    fmax: float | None = None, title: str = "") -> Any:
    """Draw the spectrogram of one channel's samples with the boxes of a ``detections``
    products group: frequency across, time running down.

    Parameters
    ----------
    g : dict
        A ``detections`` group (``time_start``, ``time_end``, ``freq_lo``, ``freq_hi``).
    x : (n,) array
        The channel's samples, in ``units``.
    fs : float
        Sample rate, Hz.
    units : str
        Sample unit (``"Pa"``, ``"FS"``; :mod:`arrayproc.io.units`).
    ax : matplotlib Axes, optional
        Where to draw (default: a new figure).
    channel, nfft, range_db, fmax
        As in :func:`plot_detections`.
    title : str
        Title; ``{n}`` is replaced by the number of detections (default: the channel's).

    Returns
    -------
    matplotlib Figure
    """
    from matplotlib.patches import Rectangle

    from arrayproc.plots.spectrogram import draw_spectrogram
    t0, t1 = g.get("time_start", np.zeros(0)), g.get("time_end", np.zeros(0))
    lo, hi = g.get("freq_lo", np.zeros(0)), g.get("freq_hi", np.zeros(0))
    if fmax is None:
        fmax = min(fs / 2, 2 * float(hi.max())) if hi.size else fs / 2
    title = (title or f"channel {channel} spectrogram with {{n}} detections").replace(
        "{n}", str(len(t0)))
    fig = draw_spectrogram(x, fs, units, ax, nfft=nfft, range_db=range_db, fmax=fmax,
                           title=title)
    ax = ax if ax is not None else fig.axes[0]
    for a, b, fl, fh in zip(t0, t1, lo, hi):
        ax.add_patch(Rectangle((fl, a), fh - fl, b - a, fill=False, ec="red", lw=1.2))
    return fig
