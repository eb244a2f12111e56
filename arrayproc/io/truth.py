"""Ground truth seen from the array: cone angles and Doppler-shifted tonal frequencies.

Used by the BTR/LOFAR truth overlays and the passive end-to-end tests. Inputs are a
:class:`~arrayproc.io.recording.Recording` with ``/truth/sources`` (simulator output) and its
``/nav`` (the array reference point and heading). Sound travels in straight lines at the
recording's sound speed; the source position is taken at the emission (retarded) time, so
cone angles and Doppler are those of the wavefront reaching the array at each time.
"""

from __future__ import annotations

import numpy as np

from arrayproc.io.text import as_text


def _interp_track(t: np.ndarray, tt: np.ndarray, pos: np.ndarray) -> np.ndarray:
    return np.stack([np.interp(t, tt, pos[:, i]) for i in range(pos.shape[1])], -1)


def sources(rec, towship: bool = True) -> dict[str, dict]:
    """The recording's truth sources by name (the tow ship, a real noise source in the data,
    included unless ``towship`` is false)."""
    if not rec.has("truth/sources"):
        return {}
    g = rec.read_group("truth/sources")
    out = {}
    for name, s in g.items():
        if name == "attrs" or not isinstance(s, dict):
            continue
        kind = s.get("attrs", {}).get("kind", "source")
        kind = as_text(kind)
        if kind not in ("source", "towship") or (kind == "towship" and not towship):
            continue
        out[name] = s
    return out


def _geometry(rec, s: dict, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Emission-time propagation delay τ (n,) s and direction vector array→source (n, 3)."""
    c = rec.sound_speed
    pa, hd, dp, _ = rec.nav.at(t)
    src_depth = float(s.get("attrs", {}).get("depth", 0.0))
    tau = np.zeros_like(t)
    for _ in range(4):  # fixed point of τ = |r_s(t − τ) − r_a(t)| / c
        ps = _interp_track(t - tau, s["time"], s["position"])
        d = np.concatenate([ps - pa, (src_depth - dp)[:, None]], axis=1)
        tau = np.linalg.norm(d, axis=1) / c
    return tau, d


def cone_angles(rec, t: np.ndarray) -> dict[str, np.ndarray]:
    """True cone angle (deg) of each source at times t (s): angle between the array's forward
    axis (its heading, horizontal) and the direction to the source at emission time."""
    t = np.asarray(t, float)
    out = {}
    _, hd, _, _ = rec.nav.at(t)
    h = np.deg2rad(hd)
    axis = np.stack([np.sin(h), np.cos(h), np.zeros_like(h)], -1)
    for name, s in sources(rec).items():
        _, d = _geometry(rec, s, t)
        cosang = np.sum(d * axis, axis=1) / np.linalg.norm(d, axis=1)
        out[name] = np.rad2deg(np.arccos(np.clip(cosang, -1, 1)))
    return out


def tonal_frequencies(rec, t: np.ndarray, dt: float = 0.5) -> dict[str, np.ndarray]:
    """Received (Doppler-shifted) frequency of each source's tonals at times t: (n_t, n_tonals)
    Hz, ``f(t − τ)·(1 − dτ/dt)`` with τ the emission-time propagation delay and f(t) = f +
    drift·t for a drifting tonal."""
    t = np.asarray(t, float)
    out = {}
    for name, s in sources(rec).items():
        f0 = np.asarray(s.get("attrs", {}).get("tonal_freqs", []), float).reshape(-1)
        if f0.size == 0:
            continue
        tp, _ = _geometry(rec, s, t + dt)
        tm, _ = _geometry(rec, s, t - dt)
        rate = (tp - tm) / (2 * dt)
        drift = np.asarray(s.get("attrs", {}).get("tonal_drift_hz_per_s", np.zeros(f0.size)),
                           float).reshape(-1)
        t_emit = t - 0.5 * (tp + tm)  # a drifting tonal's frequency at emission
        out[name] = (f0[None, :] + drift[None, :] * t_emit[:, None]) * (1.0 - rate)[:, None]
    return out
