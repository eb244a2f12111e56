"""Automatic start values of the narrowband EKF: the strongest spectral line in the input band
(``freq = "auto"``) and a conventional-beamformer scan at that line (``cone = "auto"``).

Line: the element periodograms (scipy.signal.welch, Hann, averaged over the elements) give the
bin of highest power; a parabola through the log powers of that bin and its neighbours refines
it. Cone: the cross-spectral matrix at the line (element DFTs of successive segments at the
refined frequency) is steered over cone angles 0-180° with the plane-wave weights of thesis
eq. (3.18), ``w_n = exp(−j 2π f x_n cos θ / c)``, and the power maximum refined the same way.
The scan is the narrowband CBF of thesis 3.2.1.1 written locally (stages do not import each
other).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.signal import welch


def _parabolic(p: np.ndarray, i: int) -> float:
    """Sub-bin offset of the maximum at ``i`` from a parabola through p[i-1:i+2]."""
    if i <= 0 or i >= p.size - 1:
        return 0.0
    a, b, c = p[i - 1], p[i], p[i + 1]
    den = a - 2.0 * b + c
    return 0.0 if den >= 0 else float(0.5 * (a - c) / den)


def strongest_line(y: np.ndarray, fs: float, band: tuple[float, float] | None = None,
                   fc: float = 0.0, nperseg: int | None = None) -> float:
    """Frequency (Hz) of the strongest spectral line of element samples.

    Parameters
    ----------
    y : (T, N) ndarray, real or complex
        Element samples (complex: baseband mixed down by ``fc``).
    fs : float
        Sample rate, Hz.
    band : (lo, hi) or None
        Search band in Hz (absolute, i.e. including ``fc``); None for all of it.
    fc : float
        Mixing frequency of complex input, Hz.
    nperseg : int or None
        Segment length; default the largest power of two up to a quarter of T.

    Returns
    -------
    float
        Line frequency, Hz (absolute).
    """
    t = y.shape[0]
    if nperseg is None:
        nperseg = 1 << max(3, int(math.floor(math.log2(max(t // 4, 8)))))
    nperseg = min(nperseg, t)
    cplx = np.iscomplexobj(y)
    f, p = welch(y, fs=fs, nperseg=nperseg, axis=0, return_onesided=not cplx,
                 detrend=False)
    p = p.mean(axis=1)
    f = f + fc
    order = np.argsort(f)
    f, p = f[order], p[order]
    ok = np.ones(f.size, bool) if band is None else (f >= band[0]) & (f <= band[1])
    if not ok.any():
        ok[:] = True
    i = int(np.flatnonzero(ok)[np.argmax(p[ok])])
    lp = np.log(np.maximum(p, 1e-300))
    return float(f[i] + _parabolic(lp, i) * (f[1] - f[0]))


def cone_scan(y: np.ndarray, fs: float, freq: float, x: np.ndarray, sound_speed: float,
              fc: float = 0.0, step_deg: float = 0.25, nseg: int = 8) -> tuple[float,
                                                                             np.ndarray,
                                                                             np.ndarray]:
    """Cone angle (deg) of the CBF power maximum at one frequency.

    Parameters
    ----------
    y : (T, N) ndarray, real or complex
        Element samples.
    fs : float
        Sample rate, Hz.
    freq : float
        Received line frequency (with own Doppler), Hz absolute.
    x : (N,) ndarray
        Element positions along the body x axis, m.
    sound_speed : float
        m/s.
    fc : float
        Mixing frequency of complex input, Hz.
    step_deg : float
        Scan step, deg.
    nseg : int
        Number of segments averaged in the cross-spectral matrix.

    Returns
    -------
    cone : float
        Cone angle of the maximum, deg (0 forward end-fire).
    grid : ndarray
        Scanned cone angles, deg.
    power : ndarray
        Beam power on the grid (relative).
    """
    t = y.shape[0]
    seg = max(t // nseg, 1)
    k = np.arange(seg)
    e = np.exp(-2j * np.pi * (freq - fc) * k / fs)
    snaps = np.stack([e @ y[i * seg:(i + 1) * seg] for i in range(max(t // seg, 1))])
    csm = snaps.T @ snaps.conj() / snaps.shape[0]
    grid = np.arange(0.0, 180.0 + 0.5 * step_deg, step_deg)
    w = np.exp(-2j * np.pi * freq * np.outer(np.cos(np.radians(grid)), x) / sound_speed)
    power = np.real(np.einsum("bn,nm,bm->b", w, csm, w.conj()))
    i = int(np.argmax(power))
    lp = np.log(np.maximum(power, 1e-300))
    cone = float(np.clip(grid[i] + _parabolic(lp, i) * step_deg, 0.0, 180.0))
    return cone, grid, power
