"""Raw-channel spectrogram (``plot --kind spectrogram``): one hydrophone's power spectral
density against time, frequency across and time running down as on a LOFAR-gram, in dB re
the recording's unit (µPa²/Hz for pascals). The recording may be given directly or through
a products file made from it. Only the samples inside the plot's time limits are read."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from arrayproc.errors import ArrayprocError
from arrayproc.io.units import level_label, reference_amplitude
from arrayproc.plots import finish, register_plot, subplots, write_figure
from arrayproc.plots import limits as lim
from arrayproc.plots._delay import open_recording

#: Figure size and resolution of the spectrogram.
LAYOUT = {"figsize": (8.0, 8.0), "dpi": 110}
#: Default frame length, s (rounded to a power of two of samples).
FRAME_S = 0.25


@register_plot("spectrogram")
def plot_spectrogram(path: str, out_png: str, channel: int | None = None,
                     range_db: float = 50.0, nfft: int | None = None, **_: Any) -> None:
    """Draw the spectrogram of ``channel`` (default 0) of the recording ``path`` (or of a
    products file's recording) into ``out_png`` over the plot's time and band limits
    (:func:`draw_spectrogram`)."""
    ch = 0 if channel is None else int(channel)
    L = lim.current()
    with open_recording(path, "spectrogram") as rec:
        if not 0 <= ch < rec.n_channels:
            raise ArrayprocError(f"{path}: --channel {ch} out of range (0-{rec.n_channels - 1})")
        fs, n, units = rec.fs, rec.n_samples, rec.units
        i0 = 0 if L.t0 is None else max(0, int(np.floor(L.t0 * fs)))
        i1 = n if L.t1 is None else min(n, int(np.ceil(L.t1 * fs)))
        if i1 - i0 < 16:
            raise ArrayprocError(f"{path}: no samples between --t0 and --t1 (the recording "
                                 f"spans 0-{n / fs:g} s)")
        x = rec.read(i0, i1)[:, ch].astype(float)
    if nfft is None:
        nfft = int(2 ** np.round(np.log2(max(16.0, FRAME_S * fs))))
    write_figure(lambda ax: draw_spectrogram(
        x, fs, units, ax, t_start=i0 / fs, nfft=min(int(nfft), x.size), range_db=range_db,
        fmin=L.fmin, fmax=L.fmax,
        title=f"channel {ch} spectrogram\n{Path(path).name}"), out_png, LAYOUT)


def draw_spectrogram(x: np.ndarray, fs: float, units: str, ax: Any = None,
                     t_start: float = 0.0, nfft: int = 1024, range_db: float = 50.0,
                     fmin: float | None = None, fmax: float | None = None,
                     title: str = "") -> Any:
    """Draw the spectrogram of one channel's samples: frequency across, time running down.

    PSD by :func:`scipy.signal.spectrogram` (Hann frames of ``nfft``, 50 % overlap,
    density scaling), in dB re the unit's reference squared per Hz.

    Parameters
    ----------
    x : (n,) array
        Samples, in ``units``.
    fs : float
        Sample rate, Hz.
    units : str
        Sample unit (``"Pa"``, ``"FS"``; :mod:`arrayproc.io.units`).
    ax : matplotlib Axes, optional
        Where to draw (default: a new figure).
    t_start : float
        Time of the first sample, s since the recording's start.
    nfft : int
        Frame length, samples.
    range_db : float
        Colour span below the 99.9th percentile of what is shown, dB.
    fmin, fmax : float, optional
        Band shown, Hz (default 0 to fs/2).
    title : str
        Title.

    Returns
    -------
    matplotlib Figure
    """
    from scipy.signal import spectrogram
    f, t, S = spectrogram(np.asarray(x, float), fs, window="hann", nperseg=nfft,
                          noverlap=nfft // 2, scaling="density")
    t = t + t_start
    ref2 = reference_amplitude(units) ** 2
    L = 10 * np.log10(np.maximum(S / ref2, 1e-30)).T  # (time, freq)
    keep = np.ones(f.size, bool)
    if fmin is not None:
        keep &= f >= fmin
    if fmax is not None:
        keep &= f <= fmax
    if not keep.any():
        raise ArrayprocError(f"spectrogram: no bin between --fmin {fmin} and --fmax {fmax} Hz")
    f, L = f[keep], L[:, keep]
    top = float(np.percentile(L, 99.9))
    df = f[1] - f[0] if f.size > 1 else fs / nfft
    half = nfft / fs / 2
    fig, ax, new = subplots(ax, LAYOUT)
    im = ax.imshow(L, aspect="auto", cmap="viridis", vmin=top - range_db, vmax=top,
                   extent=[f[0] - df / 2, f[-1] + df / 2, t[-1] + half, t[0] - half],
                   interpolation="nearest")
    cb = fig.colorbar(im, ax=ax, pad=0.02)
    cb.set_label(f"PSD, {level_label(units, '²/Hz')} ({range_db:g} dB range)")
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("time (s since recording start)")
    ax.set_title(title or "spectrogram", fontsize=10)
    return finish(fig, new, LAYOUT)
