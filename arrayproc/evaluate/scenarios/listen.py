"""The listening beam (``arrayproc listen``, :mod:`arrayproc.stages.beamform.beam_audio`)
against the closed-form line-array pattern, thesis eq. (2.13).

Two tonals arrive from different cones on a uniform line array; a beam is formed towards each
cone of a sweep and the amplitude of both tonals is read from the beam (a Hann-windowed
spectrum, tonals on whole bins). The beam's gain for a tonal from θ0 at f is
|I_NH(θ, θ0, f)| / N_H, which :func:`pattern_sweep` returns beside the measured one.
"""

from __future__ import annotations

import numpy as np

from arrayproc.io.geometry import line_array
from arrayproc.sim.pattern import line_array_pattern
from arrayproc.sim.plane_wave import tonal_plane_wave
from arrayproc.stages.beamform.beam_audio import delay_sum_for

#: The two tonals (cone deg, Hz), the array (N_H, δx m) and the record (fs Hz, s).
TONALS = ((60.0, 400.0), (110.0, 700.0))
N_H, SPACING, FS, SECONDS, NOISE = 16, 0.75, 4096.0, 4.0, 1e-3


def tonal_level_db(y: np.ndarray, fs: float, f: float) -> float:
    """Amplitude (dB re 1 unit) of a tone on a whole bin of a Hann-windowed spectrum."""
    w = np.hanning(y.size)
    spec = np.abs(np.fft.rfft(y * w)) * 2 / w.sum()
    k = int(round(f * y.size / fs))
    return float(20 * np.log10(spec[k - 1:k + 2].max()))


def pattern_sweep(cones: np.ndarray, seed: int = 0) -> dict[str, np.ndarray]:
    """Measured and closed-form level (dB re the tonal's amplitude at a hydrophone) of each
    tonal in the beam steered at each cone of ``cones`` (deg).

    Returns
    -------
    dict
        ``cone_deg`` (B,), ``measured_db`` and ``closed_db`` (2, B) for the two
        :data:`TONALS`, ``tonals`` (2, 2) their cones and frequencies.
    """
    rng = np.random.default_rng(seed)
    pos = line_array(N_H, SPACING)
    n = int(FS * SECONDS)
    x = sum(tonal_plane_wave(n, FS, pos, c, f, phase=0.7 * i) for i, (c, f) in
            enumerate(TONALS))
    x = x + NOISE * rng.standard_normal(x.shape)
    cones = np.asarray(cones, float)
    meas = np.empty((len(TONALS), cones.size))
    closed = np.empty_like(meas)
    core = slice(int(0.25 * FS), n - int(0.25 * FS))  # whole seconds, away from the ends
    for j, th in enumerate(cones):
        ds = delay_sum_for(pos, FS, 1500.0, cone_deg=float(th))
        y = np.concatenate([ds.process(x), ds.flush()])[core]
        for i, (c, f) in enumerate(TONALS):
            meas[i, j] = tonal_level_db(y, FS, f)
            closed[i, j] = 20 * np.log10(abs(line_array_pattern(np.array([th]), c, f, N_H,
                                                                SPACING)[0]) / N_H)
    return {"cone_deg": cones, "measured_db": meas, "closed_db": closed,
            "tonals": np.array(TONALS)}
