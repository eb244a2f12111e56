"""The ``/active`` group of a recording: the ping schedule (transmission times, each ping's
waveform), the transmitted replicas and the projector's position, as written by
:meth:`arrayproc.io.recording_writer.RecordingWriter.set_active` and read by the active stages.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

from arrayproc.errors import FormatError
from arrayproc.io.h5 import attr_str


@dataclass(frozen=True)
class Replica:
    """A transmitted waveform from ``/active/waveforms/<name>`` (docs/formats.md).

    ``samples`` float64 at ``fs`` (the recording's rate), sample 0 at the transmission start;
    ``kind`` (bpsk, hfm, cw, lfm or other), ``fc`` centre frequency (Hz), ``bandwidth`` (Hz),
    ``duration`` (s), ``bits`` (BPSK, else 0).
    """

    samples: np.ndarray
    fs: float
    kind: str
    fc: float
    bandwidth: float
    duration: float
    bits: int = 0


@dataclass(frozen=True)
class ActivePings:
    """The ping schedule of ``/active``: transmission times (s), the waveform name of each
    ping, the replicas by name and the projector's body-frame position (m)."""

    time: np.ndarray
    waveform: list[str]
    waveforms: dict[str, Replica]
    projector: np.ndarray


def read_active(f: h5py.File, p: Path, fs: float) -> ActivePings | None:
    """The ``/active`` ping schedule and replicas of an open recording, or None without it.

    ``/active/pings/waveform`` may index the sorted waveform names or hold the names.

    Parameters
    ----------
    f : h5py.File
        The open recording.
    p : Path
        Its path, for the messages.
    fs : float
        The recording's sample rate, Hz (the replicas' rate).

    Returns
    -------
    ActivePings or None
    """
    if "active" not in f:
        return None
    g = f["active"]
    try:
        names = sorted(g["waveforms"].keys())
        t = np.asarray(g["pings/time"][()], float).reshape(-1)
        wv = np.asarray(g["pings/waveform"][()]).reshape(-1)
    except KeyError as e:
        raise FormatError(f"{p}: /active needs waveforms/, pings/time and pings/waveform "
                          f"({e})") from None
    if wv.shape != t.shape or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise FormatError(f"{p}: /active/pings/time must increase and match "
                          "/active/pings/waveform")
    if wv.dtype.kind in "iu":
        if wv.size and (wv.min() < 0 or wv.max() >= len(names)):
            raise FormatError(f"{p}: /active/pings/waveform indexes a missing waveform")
        which = [names[int(i)] for i in wv]
    else:
        which = [attr_str(v) for v in wv]
        bad = [n for n in which if n not in names]
        if bad:
            raise FormatError(f"{p}: /active/pings/waveform names {bad[0]!r}, not in "
                              "/active/waveforms")
    reps = {}
    for n in names:
        d = g["waveforms"][n]
        a = d.attrs
        try:
            reps[n] = Replica(np.asarray(d[()], float).reshape(-1), fs,
                              attr_str(a["kind"]), float(a["fc"]), float(a["bandwidth"]),
                              float(a["duration"]), int(a.get("bits", 0)))
        except KeyError as e:
            raise FormatError(f"{p}: /active/waveforms/{n} lacks attribute {e}") from None
    proj = np.asarray(g.attrs.get("projector", np.zeros(3)), float).reshape(-1)
    if proj.shape != (3,):
        raise FormatError(f"{p}: /active attribute projector must hold 3 numbers")
    return ActivePings(t, which, reps, proj)
