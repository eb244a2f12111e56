"""The ``bearings`` rows of azimuth × elevation beams (``cbf_azel``, beam mode ``"azel"``).

Each integrated snapshot's power over the direction grid (dB) is peak-picked in 2-D
(:func:`arrayproc.dsp.peaks2d.pick_peaks_2d`): every local maximum ``threshold_db`` or more
above the median over directions, strongest first, at least ``min_separation`` deg (great
circle) from a stronger one, at most ``max_peaks``. A row per peak: ``azimuth_deg`` (true,
or relative to body x for an array without heading), ``elevation_deg`` (positive up),
``sigma_deg`` (σ of the azimuth from the peak's curvature, :func:`curvature_sigma`), and, so
that readers of line-array bearings see a resolved bearing, ``bearing_port_deg`` =
``bearing_stbd_deg`` = the azimuth and ``cone_deg`` the angle of the direction from the body
x axis. Levels as for cone beams (:mod:`arrayproc.stages.passive.bearings`).

With ``clean = true`` the peaks are the components of a CLEAN of the scan's power
(:mod:`arrayproc.stages.passive.azel_clean`): sources below the sidelobes of a stronger one
are found and the sidelobes are not taken for sources; ``threshold_db`` is then the
component's power over the fitted noise power (``snr_db`` holds it) and ``clean_dynamic_db``
the range below the strongest component.
"""

from __future__ import annotations

import math

import numpy as np

from arrayproc.dsp.peaks2d import curvature_sigma, pick_peaks_2d

AZEL_COLUMNS = ("azimuth_deg", "elevation_deg", "sigma_deg")


def grid_axes(beams: np.ndarray) -> tuple[np.ndarray, np.ndarray, bool]:
    """Azimuths (n_az,), elevations (n_el,) deg of an elevation-major (D, 2) beam axis, and
    whether the azimuths close the circle."""
    b = np.asarray(beams, float)
    el = np.unique(b[:, 1])
    n_az = b.shape[0] // el.size
    az = b[:n_az, 0]
    step = float(az[1] - az[0]) if n_az > 1 else 360.0
    wrap = n_az > 1 and abs(az[-1] + step - az[0] - 360.0) < 1e-6
    return az, el, wrap


def _clean(stage, level_db: np.ndarray, pattern, heading: float, az: np.ndarray,
           el: np.ndarray, wrap: bool) -> list[tuple[float, float, float, float, float]]:
    """(azimuth, elevation, level_db, curvature, snr_db) of the CLEAN components."""
    from arrayproc.stages.passive.azel_clean import clean_peaks

    top = float(np.max(level_db))
    comps, noise = clean_peaks(10 ** ((level_db - top) / 10), pattern, heading, az, el, wrap,
                               stage.threshold_db, stage.clean_dynamic_db,
                               stage.min_separation, stage.max_peaks)
    i_el = np.arange(el.size)
    out = []
    for a, e, amp, curv, _lev in comps:
        j = int(np.argmin(np.abs(i_el - np.interp(e, el, i_el)))) * az.size + \
            int(np.argmin(np.abs(((az - a + 180.0) % 360.0) - 180.0)))
        out.append((a, e, float(level_db[j]), curv, 10 * math.log10(amp / noise)))
    return out


def azel_rows(stage, level_db: np.ndarray, beams: np.ndarray, t: float, heading: float,
              f_lo: float, f_hi: float, offset_db: float, rows: dict[str, list],
              pattern=None) -> None:
    """Append the rows of one snapshot's direction powers ``level_db`` (D,) dB; with a
    ``pattern`` (:class:`~arrayproc.stages.passive.azel_clean.AzelPattern`) the CLEAN
    components."""
    az, el, wrap = grid_axes(beams)
    grid = level_db.reshape(el.size, az.size)
    noise = float(np.median(level_db))
    step = float(az[1] - az[0]) if az.size > 1 else 1.0
    if pattern is not None:
        peaks = _clean(stage, level_db, pattern, heading, az, el, wrap)
    else:
        peaks = [(a, e, lev, curv, lev - noise) for a, e, lev, curv in
                 pick_peaks_2d(grid, az, el, noise + stage.threshold_db,
                               stage.min_separation, stage.max_peaks, wrap)]
    for a, e, lev, curv, snr in peaks:
        rows["time"].append(t)
        rows["azimuth_deg"].append(a)
        rows["elevation_deg"].append(e)
        rows["sigma_deg"].append(curvature_sigma(curv, snr, step))
        rows["bearing_port_deg"].append(a)
        rows["bearing_stbd_deg"].append(a)
        cx = math.cos(math.radians(e)) * math.cos(math.radians(a - heading))
        rows["cone_deg"].append(math.degrees(math.acos(max(-1.0, min(1.0, cx)))))
        rows["level_db"].append(lev)
        rows["snr_db"].append(snr)
        rows["freq_lo"].append(f_lo)
        rows["freq_hi"].append(f_hi)
        rows["spl_db"].append(lev - offset_db)
