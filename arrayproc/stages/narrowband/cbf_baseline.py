"""Per-sample CBF bearing estimator, the baseline of thesis 3.2.1.1.

The thesis brings the beamformed data back to the time domain, takes the envelope (magnitude
of the analytic signal) of every beam, picks the strongest beam at every sample, and uses fine
beams (0.1°) computed only around the expected bearing, which it took from the Kalman filter.
Variant chosen here: the same envelope detector on 0.1° beams, but the expected bearing comes
from an independent coarse CBF scan (1° beams over 0-180°) of each ``coarse_s`` window, and the
beams are steered at that window's received line frequency (peak of the coarse beam's
spectrum), so the baseline never follows the Kalman filter (the coupling the thesis warns
about). Beams are formed by phase shifts at the line frequency on the analytic or baseband
samples (delay-and-sum for a narrowband signal). Written with numpy: a matrix product per
window.
"""

from __future__ import annotations

import math

import numpy as np

from arrayproc.stages.narrowband.amplitude import analytic
from arrayproc.stages.narrowband.initial import cone_scan, strongest_line


def cbf_track(y: np.ndarray, fs: float, x: np.ndarray, sound_speed: float, fc: float = 0.0,
              band: tuple[float, float] | None = None, coarse_s: float = 4.0,
              fine_deg: float = 0.1, half_width_deg: float = 3.0,
              speed: float = 0.0) -> dict[str, np.ndarray]:
    """Cone angle at every sample from the envelope of fine beams.

    Parameters
    ----------
    y : (T, N) ndarray, real or complex
        DFT-filtered element samples (complex: baseband mixed down by ``fc``).
    fs : float
        Sample rate, Hz.
    x : (N,) ndarray
        Element positions along the body x axis, m.
    sound_speed : float
        m/s.
    fc : float
        Mixing frequency of complex input, Hz.
    band : (lo, hi) or None
        Band searched for the line, Hz.
    coarse_s : float
        Window of the coarse scan and the line frequency, s.
    fine_deg, half_width_deg : float
        Fine-beam spacing and half-width of the fan around the coarse maximum, deg.
    speed : float
        Own speed along the array, m/s: each fine beam is steered at the water-frame
        frequency f_line / (1 + U cos θ / c), the wavelength that sets the phase across a
        moving array (steering at the received f_line biases cos θ by −U cos² θ / c).

    Returns
    -------
    dict of (T,) ndarrays
        ``cone_deg`` per sample, ``coarse_deg`` the window's coarse maximum, ``freq_hz`` the
        window's line frequency.
    """
    z = analytic(y)
    n_t = z.shape[0]
    win = max(8, int(round(coarse_s * fs)))
    cone = np.empty(n_t)
    coarse = np.empty(n_t)
    freq = np.empty(n_t)
    offs = np.arange(-half_width_deg, half_width_deg + 0.5 * fine_deg, fine_deg)
    for i0 in range(0, n_t, win):
        i1 = min(n_t, i0 + win)
        if i1 - i0 < 8:  # a short tail joins the previous window's steering
            i0 = max(0, i1 - win)
        zz = z[i0:i1]
        f_line = strongest_line(zz, fs, band, fc)
        c0, _, _ = cone_scan(zz, fs, f_line, x, sound_speed, fc, step_deg=1.0)
        fan = np.clip(c0 + offs, 0.0, 180.0)
        cf = np.cos(np.radians(fan))
        f_w = f_line / (1.0 + speed * cf / sound_speed)
        w = np.exp(-2j * np.pi * np.outer(x, f_w * cf) / sound_speed)
        env = np.abs(zz @ w)
        cone[i0:i1] = fan[np.argmax(env, axis=1)]
        coarse[i0:i1] = c0
        freq[i0:i1] = f_line
    return {"cone_deg": cone, "coarse_deg": coarse, "freq_hz": freq}


def beamwidth_deg(n: int, spacing: float, freq: float, sound_speed: float,
                  cone_deg: float = 90.0) -> float:
    """Approximate 3 dB beamwidth (deg) of a uniform line at ``cone_deg`` (0.886 λ / (L sin θ))."""
    lam = sound_speed / freq
    return math.degrees(0.886 * lam / (n * spacing * max(math.sin(math.radians(cone_deg)),
                                                        1e-3)))
