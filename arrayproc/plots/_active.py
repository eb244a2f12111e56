"""Truth of the active scenario seen from the array, for the active plots and the validation
script: every (ping, scatterer) echo with its range, range rate and horizontal cone angle.

The cone angle is the angle between the array's heading (from ``/nav``) and the horizontal
direction from the array's reference point to the scatterer, at the echo's reception time:
static clutter at ``/truth/scatterers/position0``, a target that shares a ``[[source]]``'s
track at that source's position (``/truth/sources``), other targets at their start position
(not used for moving targets here).
"""

from __future__ import annotations

import numpy as np

from arrayproc.io.text import as_text


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


def associate(contacts: dict, truth: dict, range_gate: float, cone_gate: float
              ) -> np.ndarray:
    """For each contact, the index of the nearest-in-range truth echo of the same ping within
    ``range_gate`` m and ``cone_gate`` deg, else -1."""
    out = np.full(np.asarray(contacts["range_m"]).size, -1, int)
    for i, (p, r, c) in enumerate(zip(contacts["ping"], contacts["range_m"],
                                      contacts["cone_deg"])):
        tr = truth["range_array_m"]
        m = np.flatnonzero((truth["ping"] == p) & (np.abs(tr - r) <= range_gate)
                           & (np.abs(truth["cone_deg"] - c) <= cone_gate))
        if m.size:
            out[i] = int(m[np.argmin(np.abs(tr[m] - r))])
    return out
