"""Ground truth seen from the array: cone angles and Doppler-shifted tonal frequencies.

Used by the BTR/LOFAR truth overlays, the active plots and the evaluation scenarios. Inputs
are a :class:`~arrayproc.io.recording.Recording` with ``/truth/sources`` (simulator output) and
its ``/nav`` (the array reference point and heading). Sound travels in straight lines at the
recording's sound speed; the source position is taken at the emission (retarded) time, so
cone angles and Doppler are those of the wavefront reaching the array at each time.

Active recordings (:func:`echo_truth`): every (ping, scatterer) echo of ``/truth/echoes`` with
its range, range rate and horizontal cone angle — the angle between the array's heading and
the horizontal direction from the array's reference point to the scatterer at the echo's
reception time: static clutter at ``/truth/scatterers/position0``, a target that shares a
``[[source]]``'s track at that source's position (``/truth/sources``), other targets at their
start position.
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


def relative_bearings(rec, t: np.ndarray) -> dict[str, np.ndarray]:
    """True relative bearing (deg, (−180, 180], clockwise from the array's forward axis, port
    negative) of each source at times t (s), horizontal, at emission time: the axis of the
    beams of ``lr_cbf``."""
    t = np.asarray(t, float)
    out = {}
    _, hd, _, _ = rec.nav.at(t)
    h = np.deg2rad(hd)
    fwd = np.stack([np.sin(h), np.cos(h)], -1)  # body x in the world (x east, y north)
    stbd = np.stack([np.cos(h), -np.sin(h)], -1)  # body y (starboard)
    for name, s in sources(rec).items():
        _, d = _geometry(rec, s, t)
        out[name] = np.rad2deg(np.arctan2(np.sum(d[:, :2] * stbd, axis=1),
                                          np.sum(d[:, :2] * fwd, axis=1)))
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


def echo_truth(rec) -> dict[str, np.ndarray] | None:
    """Echo truth of a simulated active recording, or None without ``/truth/echoes``.

    Returns
    -------
    dict
        ``ping``, ``time`` (reception, s), ``range_m`` (mean of the two legs),
        ``range_array_m`` (scatterer at scattering time to the array at reception),
        ``range_rate_mps``
        (opening positive), ``level_db``, ``cone_deg``, ``name`` (str), ``kind`` ("target" or
        "clutter").
    """
    if not rec.has("truth/echoes"):
        return None
    e = rec.read_group("truth/echoes")
    sc = rec.read_group("truth/scatterers")
    names = [as_text(n) for n in sc["name"]]
    kinds = [as_text(k) for k in sc["kind"]]
    pos0 = np.asarray(sc["position0"], float).reshape(-1, 3)
    srcs = {}
    if rec.has("truth/sources"):
        g = rec.read_group("truth/sources")
        srcs = {k: v for k, v in g.items() if k != "attrs" and isinstance(v, dict)}
    t = np.asarray(e["time"], float)
    tgt = np.asarray(e["target"], int)
    pa, hd, dp, _ = rec.nav.at(t)
    xy = pos0[tgt, :2].copy()
    dz = np.asarray(sc["depth"], float)[tgt] - dp
    for j, name in enumerate(names):
        if kinds[j] == "target" and name in srcs:
            s = srcs[name]
            m = tgt == j
            tt = np.asarray(s["time"], float)
            p = np.asarray(s["position"], float)
            ts = t[m].copy()
            for _ in range(3):  # position at the scattering (retarded) time
                xy[m] = np.stack([np.interp(ts, tt, p[:, 0]), np.interp(ts, tt, p[:, 1])], -1)
                ts = t[m] - np.hypot(np.linalg.norm(xy[m] - pa[m], axis=1), dz[m]) \
                    / rec.sound_speed
    d = xy - pa
    h = np.deg2rad(hd)
    cosang = (d[:, 0] * np.sin(h) + d[:, 1] * np.cos(h)) / np.linalg.norm(d, axis=1)
    return {"ping": np.asarray(e["ping"], int), "time": t,
            "range_m": np.asarray(e["range_m"], float),
            "range_array_m": np.hypot(np.linalg.norm(d, axis=1), dz),
            "range_rate_mps": np.asarray(e["range_rate_mps"], float),
            "level_db": np.asarray(e["level_db"], float),
            "cone_deg": np.rad2deg(np.arccos(np.clip(cosang, -1, 1))),
            "name": np.array([names[i] for i in tgt]), "kind": np.array([kinds[i] for i in tgt])}


def active_scene(path) -> dict:
    """The raw truth of a simulated active recording (file ``path``): ``sound_speed`` (m/s),
    ``ping_time`` (s), the ``submarine`` source's and the ``ownship``'s ``time``/``position``/
    ``velocity`` (and ownship ``heading``, deg), the scatterers' ``names``, ``kinds`` and
    horizontal ``position0`` (m), and the ``echoes`` (``ping``, ``target``, ``time``,
    ``range_m``, ``range_rate_mps``)."""
    import h5py
    with h5py.File(path, "r") as f:
        return {
            "sound_speed": float(f.attrs.get("sound_speed", 1500.0)),
            "ping_time": f["truth/pings/time"][()],
            "submarine": {k: f[f"truth/sources/submarine/{k}"][()]
                          for k in ("time", "position", "velocity")},
            "ownship": {k: f[f"truth/ownship/{k}"][()]
                        for k in ("time", "position", "velocity", "heading")},
            "names": [as_text(v) for v in f["truth/scatterers/name"][()]],
            "kinds": [as_text(v) for v in f["truth/scatterers/kind"][()]],
            "position0": f["truth/scatterers/position0"][()][:, :2],
            "echoes": {k: f[f"truth/echoes/{k}"][()]
                       for k in ("ping", "target", "time", "range_m", "range_rate_mps")},
        }
