"""Block domains, declared in one place (docs/architecture.md), with typed metadata per domain.

A block's ``domain`` names the axes of its ``data`` and the class of its ``meta``. Stages
declare which domains they accept and which they produce; :func:`arrayproc.chain.build_chain`
checks the wiring of a whole chain from those declarations before any data is read.

==================  ==============================  ======================================
domain              data axes                       meta
==================  ==============================  ======================================
``TIME``            (time, channel)                 :class:`TimeMeta`
``SPECTRA``         (snapshot, freq, channel)       :class:`SnapshotMeta`
``BEAMS``           (snapshot, freq, beam), complex :class:`SnapshotMeta`
``POWER``           (snapshot, freq, beam), real    :class:`SnapshotMeta` (``integration`` set)
``BEAM_TIME``       (time, beam), complex baseband  :class:`PingMeta`
``RANGE_DOPPLER``   (beam, range_rate, range)       :class:`PingMeta`
``CONTACTS``        (contact,)                      :class:`PingMeta`
``EVENT``           (time, channel)                 :class:`EventMeta`
``DELAYS``          (channel,)                      :class:`DelaysMeta`
==================  ==============================  ======================================
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field
from typing import Any

import numpy as np


class Domain(enum.Enum):
    """What a block holds: its axes and the class of its metadata."""

    TIME = "time"
    SPECTRA = "spectra"
    BEAMS = "beams"
    POWER = "power"
    BEAM_TIME = "beam_time"
    RANGE_DOPPLER = "range_doppler"
    CONTACTS = "contacts"
    EVENT = "event"
    DELAYS = "delays"

    @property
    def axes(self) -> tuple[str, ...]:
        """Names of the data axes."""
        return _AXES[self]

    def __str__(self) -> str:
        return f"{self.value} ({' x '.join(self.axes)})"


_AXES = {
    Domain.TIME: ("time", "channel"),
    Domain.SPECTRA: ("snapshot", "freq", "channel"),
    Domain.BEAMS: ("snapshot", "freq", "beam"),
    Domain.POWER: ("snapshot", "freq", "beam"),
    Domain.BEAM_TIME: ("time", "beam"),
    Domain.RANGE_DOPPLER: ("beam", "range_rate", "range"),
    Domain.CONTACTS: ("contact",),
    Domain.EVENT: ("time", "channel"),
    Domain.DELAYS: ("channel",),
}


@dataclass(frozen=True)
class TimeMeta:
    """Metadata of a time-series block.

    Attributes
    ----------
    sample0 : int
        Absolute index of the block's first sample in its stream (at the block's ``fs``).
    n_valid : int
        Rows of ``data`` that are samples; the rest pads the stream's last block.
    fc : float
        Centre frequency of a complex baseband stream, Hz (0 for a real stream).
    band : tuple of float or None
        Pass band (lo, hi), Hz, of a filtered stream.
    """

    sample0: int
    n_valid: int
    fc: float = 0.0
    band: tuple[float, float] | None = None


@dataclass(frozen=True)
class Synthetic:
    """How a synthetic-aperture snapshot was formed (thesis 2.2.3)."""

    snapshots: int
    rule: str
    window_start: float


@dataclass(frozen=True)
class Integration:
    """How power snapshots were integrated (thesis eq. 2.22)."""

    snapshots: int
    mode: str
    mean: bool


@dataclass(frozen=True)
class SnapshotMeta:
    """Metadata of a block of DFT snapshots (element spectra, beams or beam power).

    Attributes
    ----------
    times : (S,) ndarray
        Centre time of each snapshot, s since the recording start.
    headings : (S,) ndarray
        Array heading at each snapshot, deg.
    nfft, hop : int
        DFT length and hop of the frames, samples.
    window : str
        Time taper of the frames.
    df : float
        Bin spacing, Hz.
    starts : (S,) ndarray or None
        First sample of each snapshot's frame, on the stream's sample grid.
    positions_xy : (S, 2) ndarray or None
        Array reference point at each snapshot, m.
    speeds : (S,) ndarray or None
        Speed over ground at each snapshot, m/s.
    shading : str
        Array shading of the beams.
    beam_mode : str
        ``"cone"`` (line array cone angles) or ``"3d"``.
    synthetic : Synthetic or None
        Set on synthetic-aperture beams.
    integration : Integration or None
        Set on integrated power.
    """

    times: np.ndarray
    headings: np.ndarray
    nfft: int
    hop: int
    window: str
    df: float
    starts: np.ndarray | None = None
    positions_xy: np.ndarray | None = None
    speeds: np.ndarray | None = None
    shading: str = "none"
    beam_mode: str = "cone"
    synthetic: Synthetic | None = None
    integration: Integration | None = None


@dataclass(frozen=True)
class PingMeta:
    """Metadata of one active-sonar ping's blocks (beam series, range-Doppler, contacts).

    Attributes
    ----------
    ping : int
        Index of the ping in ``/active/pings``.
    waveform : str
        Name of the transmitted replica in ``/active/waveforms``.
    t_ping : float
        Transmission time, s since the recording start.
    fc : float
        Centre frequency of the complex baseband, Hz.
    speed, heading : float
        Ownship speed (m/s) and heading (deg) at the ping.
    projector : (3,) ndarray
        Projector position in the body frame, m.
    extra : dict
        Stage-specific values (plans, counters) that travel with the ping.
    """

    ping: int
    waveform: str
    t_ping: float = 0.0
    fc: float = 0.0
    speed: float = 0.0
    heading: float = 0.0
    projector: np.ndarray = field(default_factory=lambda: np.zeros(3))
    extra: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class EventMeta:
    """Metadata of a transient event block (the multichannel samples of one detection).

    Attributes
    ----------
    event : int
        Running number of the detection.
    sample0 : int
        Absolute index of the block's first sample in the recording.
    time_start, time_end : float
        The detection's time box, s (the block is padded around it).
    freq_lo, freq_hi : float
        The detection's band, Hz.
    snr_db : float
        Detection SNR, dB.
    channel : int
        Reference channel of the detection.
    """

    event: int
    sample0: int
    time_start: float
    time_end: float
    freq_lo: float
    freq_hi: float
    snr_db: float
    channel: int


@dataclass(frozen=True)
class DelaysMeta:
    """One row of delays (a ``DELAYS`` block's data: (n_ch,) s relative to the reference) with
    what localisation needs.

    Attributes
    ----------
    time : float
        Time of the row, s since the recording start.
    sigma, corr : (n_ch,) ndarray
        Standard deviation (s) and normalised peak correlation of each delay.
    reference : int
        Reference channel.
    elements : (n_ch, 3) ndarray
        Element positions in the world frame (x east, y north, z down), m.
    sound_speed : float
        m/s.
    event : int
        Detection number, or -1 for a regular snapshot.
    source : int
        Source hypothesis of the row within its snapshot (``tde`` with ``peaks`` > 1), or -1
        for the one-source row.
    """

    time: float
    sigma: np.ndarray
    corr: np.ndarray
    reference: int
    elements: np.ndarray
    sound_speed: float
    event: int = -1
    source: int = -1


META_TYPES: dict[Domain, type] = {
    Domain.TIME: TimeMeta,
    Domain.SPECTRA: SnapshotMeta,
    Domain.BEAMS: SnapshotMeta,
    Domain.POWER: SnapshotMeta,
    Domain.BEAM_TIME: PingMeta,
    Domain.RANGE_DOPPLER: PingMeta,
    Domain.CONTACTS: PingMeta,
    Domain.EVENT: EventMeta,
    Domain.DELAYS: DelaysMeta,
}
