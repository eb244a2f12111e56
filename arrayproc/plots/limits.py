"""Time and frequency limits of a plot (``plot --t0 --t1 --fmin --fmax``).

Every plot whose axis is time (``time (s…)``, ``time (min…)``) or frequency
(``frequency (Hz)``) honours them: :func:`apply` sets those axes' limits on the finished
figure, keeping a time axis that runs down running down, so each plotter needs no option
of its own. The plots of arrays (BTR, LOFAR, bearings, bearing-frequency, spectrogram) also
select the rows and bins inside the limits before drawing (:func:`rows`, :func:`bins`), so
their colour scales are those of what is shown. :func:`plot_file
<arrayproc.plots.plot_file>` sets the limits for the duration of one plot
(:data:`CURRENT`).
"""

from __future__ import annotations

from contextvars import ContextVar
from dataclasses import dataclass
from typing import Any

import numpy as np

from arrayproc.errors import ArrayprocError


@dataclass(frozen=True)
class Limits:
    """Time window [t0, t1] s since the recording's start and band [fmin, fmax] Hz; None:
    unlimited on that side."""

    t0: float | None = None
    t1: float | None = None
    fmin: float | None = None
    fmax: float | None = None

    def __post_init__(self) -> None:
        for name in ("t0", "t1", "fmin", "fmax"):
            v = getattr(self, name)
            if v is not None and not np.isfinite(v):
                raise ArrayprocError(f"--{name} must be a finite number, got {v}")
        for lo, hi, what in ((self.t0, self.t1, "--t0 must be below --t1"),
                             (self.fmin, self.fmax, "--fmin must be below --fmax")):
            if lo is not None and hi is not None and not lo < hi:
                raise ArrayprocError(f"{what} (got {lo:g} and {hi:g})")
        if self.fmin is not None and self.fmin < 0:
            raise ArrayprocError(f"--fmin must be >= 0 Hz, got {self.fmin:g}")

    @property
    def any(self) -> bool:
        """Whether any limit is set."""
        return any(v is not None for v in (self.t0, self.t1, self.fmin, self.fmax))


#: The limits of the plot being drawn (unlimited outside :func:`arrayproc.plots.plot_file`).
CURRENT: ContextVar[Limits | None] = ContextVar("plot_limits", default=None)


def current() -> Limits:
    """The limits of the plot being drawn."""
    return CURRENT.get() or Limits()


def _inside(x: np.ndarray, lo: float | None, hi: float | None) -> np.ndarray:
    x = np.asarray(x, float)
    m = np.ones(x.shape, bool)
    if lo is not None:
        m &= x >= lo
    if hi is not None:
        m &= x <= hi
    return m


def rows(t: np.ndarray, lim: Limits | None = None, what: str = "") -> np.ndarray:
    """Indices of the times ``t`` inside [t0, t1]; ArrayprocError naming ``what`` when the
    window holds none."""
    lim = lim or current()
    idx = np.flatnonzero(_inside(t, lim.t0, lim.t1))
    if idx.size == 0 and np.size(t):
        raise ArrayprocError(f"{what or 'plot'}: no rows between --t0 {lim.t0} and --t1 "
                             f"{lim.t1} s (the data span {np.min(t):g}-{np.max(t):g} s)")
    return idx


def bins(f: np.ndarray, lim: Limits | None = None, what: str = "") -> np.ndarray:
    """Indices of the frequencies ``f`` inside [fmin, fmax]; ArrayprocError when none."""
    lim = lim or current()
    idx = np.flatnonzero(_inside(f, lim.fmin, lim.fmax))
    if idx.size == 0 and np.size(f):
        raise ArrayprocError(f"{what or 'plot'}: no bins between --fmin {lim.fmin} and "
                             f"--fmax {lim.fmax} Hz (the data span {np.min(f):g}-"
                             f"{np.max(f):g} Hz)")
    return idx


def select(g: dict, idx: np.ndarray, n: int) -> dict:
    """A products group with only rows ``idx`` of every column that has ``n`` rows (axes
    and attributes unchanged)."""
    out = dict(g)
    for k, v in g.items():
        if isinstance(v, np.ndarray) and v.ndim and v.shape[0] == n and k != "attrs":
            out[k] = v[idx]
    return out


def _span(lim: Limits, label: str) -> tuple[float | None, float | None] | None:
    """The limits an axis of this label takes (None: not a time or frequency axis)."""
    s = label.lower()
    if s.startswith("time (s") or s.startswith("time (min"):
        k = 60.0 if "(min" in s else 1.0
        return (None if lim.t0 is None else lim.t0 / k, None if lim.t1 is None else lim.t1 / k)
    if s.startswith("frequency (hz") or s.startswith("frequency estimate (hz"):
        return lim.fmin, lim.fmax
    return None


def apply(fig: Any, lim: Limits | None = None) -> None:
    """Set the limits on every time and frequency axis of a matplotlib figure, keeping an
    inverted (time running down) axis inverted."""
    lim = lim or current()
    if not lim.any:
        return
    for ax in fig.axes:
        for label, get, put in ((ax.get_xlabel(), ax.get_xlim, ax.set_xlim),
                                (ax.get_ylabel(), ax.get_ylim, ax.set_ylim)):
            span = _span(lim, label)
            if span is None or span == (None, None):
                continue
            a, b = get()
            down = a > b
            lo, hi = min(a, b), max(a, b)
            lo = lo if span[0] is None else span[0]
            hi = hi if span[1] is None else span[1]
            put((hi, lo) if down else (lo, hi))
