"""``beam_audio``: the time series of one beam, to listen to (delay-and-sum in the time domain).

For a steering direction k (a cone angle θ for line arrays, or a bearing and elevation), each
element is delayed by its plane-wave advance over the centroid and the shaded elements are
averaged,

    y(t) = Σ_n w_n x_n(t − τ_n) / Σ_n w_n,        τ_n = (r_n − r̄)·k / c,            (1)

the time-domain form of the CBF's eq. (2.8) (:mod:`arrayproc.stages.beamform.cbf`, same
τ_n and shading): a plane wave from k passes with gain 1 and one from k0 at frequency f with
|Σ_n w_n e^{j2πf(τ_n(k0) − τ_n(k))}| / Σ_n w_n, which for a uniform unshaded line array is
|I_NH(θ, θ0, f)| / N_H of eq. (2.13) (:func:`arrayproc.sim.pattern.line_array_pattern`).
For cone beams only each element's body-x coordinate enters (the cone's projection on the
array axis), as in the CBF. The fractional delays are read exactly by the Kaiser-windowed sinc
of :mod:`arrayproc.dsp.fracdelay`, here with 16 taps each side (:data:`HALF_WIDTH`): a
recording is not oversampled as the simulator's sources are, and the simulator's 6 taps
are accurate only to 0.3 of the sample rate, these to −70 dB up to 0.4 of it (measured on
a unit sinusoid at a delay of 0.37 sample: −71.7 dB at 0.4 fs, −25 dB at 0.45 fs). The
nearest-phase table quantises a delay to 1/8192 sample. Any geometry is thus steered
without rounding delays to samples. An optional ``band`` is a Butterworth band-pass (order 8,
``scipy.signal``) applied to the beam, streaming.

:class:`DelaySum` streams (1) block by block with the history and look-ahead the delays
need; its output is aligned with the input (sample k of the beam is time k/fs of the
recording) and has the input's length. The stage ``beam_audio`` runs it in a chain, passes
its input blocks on and, when the stream ends, writes the beam as a WAV file normalised to
``peak_dbfs`` (:func:`arrayproc.io.audio.write_beam_wav`). :func:`beam_series` does the same
from a recording for ``arrayproc listen``. The beam of one segment is kept in memory (4 bytes
per sample: an hour at 48 kHz is 0.7 GB).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterator
from typing import Any

import numpy as np

from arrayproc.chain import Param, Stage, register
from arrayproc.chain.block import Block
from arrayproc.chain.domains import Domain
from arrayproc.dsp import fracdelay
from arrayproc.dsp.bands import check_nyquist
from arrayproc.dsp.shading import KINDS as SHADINGS
from arrayproc.dsp.shading import shading_weights
from arrayproc.errors import ConfigError

_log = logging.getLogger(__name__)

#: Taps on each side of the fractional-delay kernel (module doc), and its Kaiser β.
HALF_WIDTH, KAISER_BETA = 16, 8.0
_TABLE: list[np.ndarray] = []


def delay_table() -> np.ndarray:
    """The polyphase table of the beam's fractional delays (made once, 1 MB)."""
    if not _TABLE:
        _TABLE.append(fracdelay.make_table(HALF_WIDTH, KAISER_BETA))
    return _TABLE[0]


def steering_direction(cone_deg: float | None = None, bearing_deg: float | None = None,
                       elevation_deg: float = 0.0) -> tuple[np.ndarray, str]:
    """Body-frame unit vector and mode (``"cone"`` or ``"3d"``) of a steering direction.

    A cone angle θ (0 forward end-fire, 90 broadside) gives (cos θ, sin θ, 0) with mode
    ``"cone"`` (only its x enters); a bearing relative to the array's forward axis (clockwise
    seen from above) and an elevation (up) give the 3-D vector of
    :func:`arrayproc.geo.beams.beam_directions`.
    """
    if (cone_deg is None) == (bearing_deg is None):
        raise ConfigError("beam direction: give a cone angle or a bearing (one of them)")
    if cone_deg is not None:
        if not (math.isfinite(cone_deg) and 0.0 <= cone_deg <= 180.0):
            raise ConfigError(f"cone angle must lie in [0, 180] deg, got {cone_deg:g}")
        th = math.radians(cone_deg)
        return np.array([math.cos(th), math.sin(th), 0.0]), "cone"
    if not (math.isfinite(bearing_deg) and math.isfinite(elevation_deg)
            and abs(elevation_deg) <= 90.0):
        raise ConfigError("bearing must be finite and elevation in [-90, 90] deg")
    b, e = math.radians(bearing_deg), math.radians(elevation_deg)
    return np.array([math.cos(e) * math.cos(b), math.cos(e) * math.sin(b), -math.sin(e)]), "3d"


def steering_advances(positions: np.ndarray, direction: np.ndarray, mode: str,
                      sound_speed: float) -> np.ndarray:
    """τ_n of eq. (1), s: the plane-wave advance of each element over the centroid (cone mode:
    body x only)."""
    rel = np.asarray(positions, float) - np.asarray(positions, float).mean(axis=0)
    if mode == "cone":
        rel[:, 1:] = 0.0
    return rel @ np.asarray(direction, float) / sound_speed


class DelaySum:
    """Streaming delay-and-sum of one direction, eq. (1) (module doc).

    Parameters
    ----------
    advances : (n_channels,) array
        τ_n, s.
    weights : (n_channels,) array
        Shading w_n.
    fs : float
        Sample rate, Hz.
    band : (lo, hi), optional
        Band-pass of the beam, Hz.

    :meth:`process` takes consecutive blocks (n, n_channels) and returns the beam samples
    that are complete; :meth:`flush` returns the rest, so the outputs concatenated have the
    input's length.
    """

    def __init__(self, advances: np.ndarray, weights: np.ndarray, fs: float,
                 band: tuple[float, float] | None = None) -> None:
        self.shift = -np.asarray(advances, float) * fs  # read x_n at k + shift_n
        self.w = np.asarray(weights, float) / np.sum(weights)
        self.table = delay_table()
        half = self.table.shape[1] // 2
        self.past = int(math.ceil(max(0.0, -self.shift.min()))) + half + 2
        self.future = int(math.ceil(max(0.0, self.shift.max()))) + half + 2
        self.buf = np.zeros((self.past, self.shift.size))
        self.start = -self.past  # absolute index of buf[0]
        self.received = 0
        self.done = 0  # beam samples returned
        self.sos = None
        if band is not None:
            from scipy.signal import butter, sosfilt_zi
            lo, hi = float(band[0]), float(band[1])
            self.sos = (butter(8, hi, btype="lowpass", fs=fs, output="sos") if lo <= 0 else
                        butter(8, lo, btype="highpass", fs=fs, output="sos") if hi >= fs / 2
                        else butter(4, (lo, hi), btype="bandpass", fs=fs, output="sos"))
            self.zi = sosfilt_zi(self.sos) * 0.0

    def _emit(self, stop: int) -> np.ndarray:
        """Beam samples [done, stop) from the buffer."""
        k = np.arange(self.done, stop, dtype=float)
        y = np.zeros(k.size)
        for c in range(self.shift.size):
            u = (k + self.shift[c] - self.start)[:, None]
            y += self.w[c] * fracdelay.interpolate(np.ascontiguousarray(self.buf[:, c]), u,
                                                   self.table)[:, 0]
        self.done = stop
        keep = self.done - self.past - self.start  # history the next samples need
        if keep > 0:
            self.buf = self.buf[keep:]
            self.start += keep
        if self.sos is not None and y.size:
            from scipy.signal import sosfilt
            y, self.zi = sosfilt(self.sos, y, zi=self.zi)
        return y

    def process(self, x: np.ndarray) -> np.ndarray:
        """Add samples (n, n_channels); returns the beam samples now complete."""
        x = np.asarray(x, float)
        self.buf = np.concatenate([self.buf, x]) if x.size else self.buf
        self.received += x.shape[0]
        return self._emit(max(self.done, self.received - self.future))

    def flush(self) -> np.ndarray:
        """The last beam samples (the input's end padded with zeros)."""
        self.buf = np.concatenate([self.buf, np.zeros((self.future, self.shift.size))])
        return self._emit(self.received)


def delay_sum_for(positions: np.ndarray, fs: float, sound_speed: float,
                  cone_deg: float | None = None, bearing_deg: float | None = None,
                  elevation_deg: float = 0.0, shading: str = "none",
                  sidelobe_db: float = 30.0,
                  band: tuple[float, float] | None = None) -> DelaySum:
    """A :class:`DelaySum` steered at a cone angle or a bearing/elevation, shaded."""
    direction, mode = steering_direction(cone_deg, bearing_deg, elevation_deg)
    if band is not None:
        check_nyquist(band, fs / 2, "band")
        if not (0 <= band[0] < band[1]):
            raise ConfigError(f"band [{band[0]:g}, {band[1]:g}] Hz: need 0 <= lo < hi")
    tau = steering_advances(positions, direction, mode, sound_speed)
    _log.debug(f"beam: delays {tau.min() * fs:+.3f} to {tau.max() * fs:+.3f} samples over "
               f"{tau.size} elements, shading {shading}")
    return DelaySum(tau, shading_weights(shading, positions, sidelobe_db), fs, band)


def beam_series(recording: Any, start_s: float = 0.0, duration_s: float | None = None,
                block: int = 1 << 16, **steer: Any) -> np.ndarray:
    """The beam of eq. (1) over a segment of an open recording (float32, the recording's
    unit), aligned with its samples; ``steer``: the keywords of :func:`delay_sum_for`.

    The recording's first pose gives the element positions (a static or rigid array).
    """
    i0 = max(0, int(round(start_s * recording.fs)))
    i1 = recording.n_samples if duration_s is None else min(
        recording.n_samples, i0 + int(round(duration_s * recording.fs)))
    ds = delay_sum_for(recording.positions, recording.fs, recording.sound_speed, **steer)
    parts = []
    for s in range(i0, i1, block):
        parts.append(ds.process(recording.read(s, min(i1, s + block), np.float64)))
    parts.append(ds.flush())
    return np.concatenate(parts).astype(np.float32)


@register
class BeamAudio(Stage):
    """The time series of one beam (delay-and-sum with fractional delays), written as a WAV
    file when the stream ends; blocks pass on (module doc)."""

    kind = "beam_audio"
    accepts = frozenset({Domain.TIME})
    params = {
        "output": Param("str", None, "WAV file to write (relative to the working directory)"),
        "cone_deg": Param("float", None, "cone angle of the beam (line arrays), deg",
                          unit="deg"),
        "bearing_deg": Param("float", None, "bearing of the beam relative to the array's "
                             "forward axis, clockwise (3-D arrays), deg", unit="deg"),
        "elevation_deg": Param("float", 0.0, "elevation of the beam, up, with bearing_deg",
                               unit="deg"),
        "band": Param("band", None, "[lo, hi] Hz band-pass of the beam (default: none)",
                      unit="Hz"),
        "shading": Param("str", "none", "array shading", choices=SHADINGS),
        "sidelobe_db": Param("float", 30.0, "sidelobe level of taylor/chebyshev shading, dB",
                             unit="dB"),
        "peak_dbfs": Param("float", -1.0, "peak of the normalised WAV, dB re full scale",
                           unit="dBFS"),
    }

    def validate(self) -> None:
        if not self.output:
            raise ConfigError(f"stage {self.name!r}: key 'output' (the WAV file) is required")
        steering_direction(self.cone_deg, self.bearing_deg, self.elevation_deg)
        if not (math.isfinite(self.peak_dbfs) and self.peak_dbfs <= 0):
            raise ConfigError(f"stage {self.name!r}: key 'peak_dbfs' must be <= 0")

    def process(self, blocks: Iterator[Block]) -> Iterator[Block]:
        from arrayproc.io.audio import write_beam_wav
        from arrayproc.io.units import recording_units
        ds, parts, fs = None, [], self.fs_in
        for b in blocks:
            if ds is None:
                fs = b.fs
                ds = delay_sum_for(b.positions, b.fs, self.ctx.sound_speed, self.cone_deg,
                                   self.bearing_deg, self.elevation_deg, self.shading,
                                   self.sidelobe_db, self.band)
            parts.append(ds.process(b.data[:b.meta.n_valid]).astype(np.float32))
            yield b
        if ds is None:
            return
        parts.append(ds.flush().astype(np.float32))
        write_beam_wav(self.output, np.concatenate(parts), fs, self.peak_dbfs,
                       units=recording_units(self.ctx.recording), what=self._what())

    def _what(self) -> str:
        d = (f"cone {self.cone_deg:g} deg" if self.cone_deg is not None
             else f"bearing {self.bearing_deg:g} deg, elevation {self.elevation_deg:g} deg")
        return d + (f", band {self.band[0]:g}-{self.band[1]:g} Hz" if self.band else "")
