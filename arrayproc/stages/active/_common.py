"""Helpers shared by the active stages: the ping schedule of the recording, the waveform's
processing band, and the per-run board on which a ``cfar`` stage posts each ping's contacts
for a ``matched_filter`` stage in bracket mode (thesis 4.2.3)."""

from __future__ import annotations

from typing import Any

import numpy as np

from arrayproc.errors import ConfigError

from .bank import DOPPLER_INSENSITIVE

DOPPLER_MARGIN_MPS = 15.0  # band widening for the Doppler of the default band


def schedule(recording: Any, where: str):
    """The recording's ``/active`` ping schedule (:class:`arrayproc.io.recording.ActivePings`).

    Raises ConfigError naming the stage when there is no recording or no ``/active`` group.
    """
    if recording is None or not hasattr(recording, "active"):
        raise ConfigError(f"{where}: needs a recording with an /active group (ping times and "
                          "replicas)")
    act = recording.active()
    if act is None:
        raise ConfigError(f"{where}: recording {getattr(recording, 'path', '')} has no /active "
                          "group (ping times and replicas)")
    return act


def default_band(wf: Any, c: float, fs: float) -> tuple[float, float]:
    """Processing band (Hz) of a replica: the BPSK/CW main lobe fc +- B (B = N/T, the first
    nulls), an FM sweep's band, each widened by the two-way Doppler of +-15 m/s."""
    if wf.kind in DOPPLER_INSENSITIVE or wf.kind not in ("bpsk", "cw"):
        lo, hi = wf.fc - wf.bandwidth / 2, wf.fc + wf.bandwidth / 2
    else:
        lo, hi = wf.fc - wf.bandwidth, wf.fc + wf.bandwidth
    k = 2 * DOPPLER_MARGIN_MPS / c
    return max(0.0, lo * (1 - k)), min(0.5 * fs * 0.999, hi * (1 + k))


def insensitive(kind: str) -> bool:
    """Whether a waveform kind is Doppler insensitive (one replica)."""
    return kind in DOPPLER_INSENSITIVE


def board(ctx: Any) -> dict:
    """The run's contact board: stage name -> list of (ping, waveform kind, contacts dict)."""
    b = getattr(ctx, "_active_contacts", None)
    if b is None:
        b = {}
        ctx._active_contacts = b
    return b


def post(ctx: Any, stage: str, ping: int, kind: str, contacts: dict) -> None:
    """Post one ping's contacts of ``stage`` (kept: the last 8 pings)."""
    lst = board(ctx).setdefault(stage, [])
    lst.append((int(ping), kind, contacts))
    del lst[:-8]


def previous_insensitive(ctx: Any, stage: str, ping: int) -> tuple[int, dict] | None:
    """The most recent contacts of ``stage`` from a Doppler-insensitive ping before ``ping``."""
    for p, kind, c in reversed(board(ctx).get(stage, [])):
        if p < ping and insensitive(kind):
            return p, c
    return None


def shading(kind: str, positions: np.ndarray) -> np.ndarray:
    """Element weights (mean 1) along the array's body-x order: none, hann, hamming."""
    n = positions.shape[0]
    if kind == "none" or n < 3:
        return np.ones(n)
    from scipy.signal import get_window
    order = np.argsort(positions[:, 0], kind="stable")
    w = np.empty(n)
    w[order] = get_window(kind, n, fftbins=False)
    return w / w.mean()
