"""Contacts mode on active-sonar contacts as the ``cfar`` stage writes them: every row's
``time`` is its echo's reception time (the ping time + 2r/c), a ``ping`` column, both
candidate bearings of a line array, the absolute-Doppler ``moving`` flag (thesis eq. 4.9).

A seeded case of ten pings 30 s apart: a towed line array running south, then turning 40°
to port; a submarine at ~3.6 km moving at 3 m/s; 15 still clutter scatterers detected on 80 %
of the pings; 40 noise false alarms per ping with uniform range rates and SNRs of 12.4 dB
(the CFAR threshold) plus an exponential excess of mean 1.5 dB (a fifth of them above the
tracker's 15 dB). Through the products
path with the shipped ``data/trackers/active_contacts.toml``: the submarine is held by one
confirmed track from its third ping to the end, no still scatterer is ever confirmed, its
port/starboard mirror image is confirmed only until the turn, and a track started by noise
false alarms is confirmed for at most three pings."""

from __future__ import annotations

import math
from importlib import resources

import numpy as np
import pytest

from arrayproc.io.products import ProductsWriter, read_products
from arrayproc.io.recording import RecordingWriter
from arrayproc.track.manage.tracks import status_names
from arrayproc.track.multi import contact_scans
from arrayproc.track.runner import run_tracker

C = 1500.0
U = 6 * 0.514444                 # ownship speed, m/s
PINGS = 1.0 + 30.0 * np.arange(10)
SUB0 = np.array([3300.0, -1500.0])
SUB_V = U * np.array([math.sin(math.radians(100.0)), math.cos(math.radians(100.0))])
NOISE = (1.0, 5.0, 0.15)         # bearing deg, range m, range rate m/s
MOVING_MPS = 2 * 0.514444        # the cfar stage's moving_threshold, 2 kn


def _nav() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Ownship fixes every 0.5 s: south for 130 s, then a 1°/s turn to port onto 140°."""
    t = np.arange(0.0, 320.5, 0.5)
    hd = np.where(t <= 130.0, 180.0, np.maximum(140.0, 180.0 - (t - 130.0)))
    v = U * np.stack([np.sin(np.radians(hd)), np.cos(np.radians(hd))], 1)
    pos = np.vstack([[0.0, 0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) / 2, axis=0)])
    return t, pos, hd


def _own(nav, t):
    tn, pos, hd = nav
    p = np.array([np.interp(t, tn, pos[:, i]) for i in range(2)])
    h = float(np.interp(t, tn, hd))
    return p, U * np.array([math.sin(math.radians(h)), math.cos(math.radians(h))]), h


def _contact(nav, tp, pos_fn, vel, rng):
    """One echo of the ping at ``tp`` from a scatterer at ``pos_fn(t)`` with velocity
    ``vel``: the geometry at the scattering time, received at tp + 2r/c."""
    ts = tp
    for _ in range(3):  # fixed point of t_sc = tp + r(t_sc) / c
        o, _v, _h = _own(nav, ts)
        r = float(np.linalg.norm(pos_fn(ts) - o))
        ts = tp + r / C
    o, vo, h = _own(nav, ts)
    d = pos_fn(ts) - o
    r = float(np.hypot(*d))
    u = d / r
    brg = math.degrees(math.atan2(d[0], d[1]))
    rel = (brg - h + 180.0) % 360.0 - 180.0
    cone = abs(rel) + NOISE[0] * rng.standard_normal()
    rdot = float(u @ (vel - vo)) + NOISE[2] * rng.standard_normal()
    absd = rdot + U * math.cos(math.radians(cone))
    return {"time": tp + 2 * r / C, "range_m": r + NOISE[1] * rng.standard_normal(),
            "cone_deg": cone, "bearing_port_deg": (h - cone) % 360,
            "bearing_stbd_deg": (h + cone) % 360, "range_rate_mps": rdot,
            "absolute_doppler_mps": absd, "moving": abs(absd) > MOVING_MPS, "snr_db": 20.0}


def _sub(t):
    return SUB0 + SUB_V * t


def _files(tmp_path, seed: int = 11):
    rng = np.random.default_rng(seed)
    nav = _nav()
    rec = tmp_path / "rec.h5"
    with RecordingWriter(rec, 100.0, 1, start_time="2026-01-01T00:00:00Z") as w:
        w.append(np.zeros((100, 1), np.float32))
        w.set_nav(*nav)
    ang = rng.uniform(0, 2 * math.pi, 15)
    clutter = np.stack([np.sin(ang), np.cos(ang)], 1) * rng.uniform(3000, 8000, (15, 1)) \
        + np.array([0.0, -500.0])
    rows = []
    for k, tp in enumerate(PINGS):
        rows.append(_contact(nav, tp, _sub, SUB_V, rng) | {"ping": k})
        for c in clutter[rng.random(15) < 0.8]:
            rows.append(_contact(nav, tp, lambda t, c=c: c, np.zeros(2), rng) | {"ping": k})
        o, vo, h = _own(nav, tp)
        for _ in range(rng.poisson(40)):
            r, cone, rdot = rng.uniform(150, 15000), rng.uniform(0, 180), rng.uniform(-8, 8)
            absd = rdot + U * math.cos(math.radians(cone))
            rows.append({"time": tp + 2 * r / C, "range_m": r, "cone_deg": cone,
                         "bearing_port_deg": (h - cone) % 360,
                         "bearing_stbd_deg": (h + cone) % 360, "range_rate_mps": rdot,
                         "absolute_doppler_mps": absd, "moving": abs(absd) > MOVING_MPS,
                         "snr_db": 12.4 + rng.exponential(1.5), "ping": k})
    prod = tmp_path / "prod.h5"
    cols = {k: np.array([r[k] for r in rows]) for k in rows[0]}
    with ProductsWriter(prod, source=str(rec)) as w:
        w.group("contacts", "contacts").append(
            **cols, waveform=np.array([b"bpsk"] * len(rows)))
    return nav, clutter, str(prod)


def _config(tmp_path, moving_only: bool = True) -> str:
    text = resources.files("arrayproc.data").joinpath("trackers/active_contacts.toml") \
        .read_text(encoding="utf-8")
    if not moving_only:
        assert "moving_only = true" in text
        text = text.replace("moving_only = true", "moving_only = false")
    p = tmp_path / "active_contacts.toml"
    p.write_text(text, encoding="utf-8")
    return str(p)


def _mirror(nav, t, p):
    """Mirror image of point p across the array's axis (the ownship's heading line) at t."""
    o, _v, h = _own(nav, t)
    a = np.array([math.sin(math.radians(h)), math.cos(math.radians(h))])
    d = p - o
    return o + 2 * (d @ a) * a - d


def _confirmed(out):
    g = read_products(out)["tracks"]
    conf = status_names(g["status"]) == "confirmed"
    return {k: np.asarray(g[k])[conf] for k in ("track_id", "time", "x", "y")}


def test_scans_per_ping_at_transmission_time(tmp_path):
    nav, _clutter, prod = _files(tmp_path)
    from arrayproc.io.recording import Recording
    g = read_products(prod)["contacts"]
    c = {k: np.asarray(g[k], float) for k in ("time", "range_m", "bearing_port_deg",
                                             "bearing_stbd_deg", "range_rate_mps")}
    c["ping"] = np.asarray(g["ping"], np.int64)
    with Recording(str(tmp_path / "rec.h5"), require_geometry=False) as r:
        scans = contact_scans(c, r.nav, True, C)
    assert len(scans) == PINGS.size
    # the noise-free echo times give t − 2r/c = ping time; range noise 5 m is 7 ms of it
    np.testing.assert_allclose([s[0] for s in scans], PINGS, atol=0.03)
    # each range carried back to the ping time along its range rate: r − ṙ r/c (first order)
    t0, Z, rows, own = scans[0]
    r_m, rd = c["range_m"][rows], c["range_rate_mps"][rows]
    t_sc = c["time"][rows] - r_m / C
    np.testing.assert_allclose(Z[:, 1], r_m - rd * (t_sc - t0), rtol=0, atol=1e-9)
    o, _v, _h = _own(nav, t0)
    np.testing.assert_allclose(own[:2], o, atol=1e-6)


def test_submarine_one_track_clutter_never_confirmed(tmp_path):
    nav, clutter, prod = _files(tmp_path)
    out = str(tmp_path / "tracks.h5")
    run_tracker(prod, _config(tmp_path), out)
    c = _confirmed(out)
    assert c["time"].size
    xy = np.stack([c["x"], c["y"]], 1)
    sub = np.array([_sub(t) for t in c["time"]])
    on_sub = np.linalg.norm(xy - sub, axis=1) < 300.0
    # one track holds the submarine at every ping from its third (confirmation) on
    ids = np.unique(c["track_id"][on_sub])
    assert ids.size == 1, f"submarine held by tracks {ids}"
    held = np.unique(np.round(c["time"][on_sub]))
    assert held.size == PINGS.size - 2
    # no confirmed track near a still scatterer, at any ping
    d_cl = np.linalg.norm(xy[:, None] - clutter[None], axis=-1).min(1)
    assert d_cl.min() > 300.0
    # the submarine's mirror image is held until the turn parts it, and no new image track
    # starts after it (the echo's other bearing already updated the submarine's track);
    # anything else was started by noise false alarms: confirmed for at most three pings
    mir = np.array([_mirror(nav, t, _sub(t)) for t in c["time"]])
    on_mirror = np.linalg.norm(xy - mir, axis=1) < 300.0
    n_mirror = 0
    for i in np.unique(c["track_id"]):
        m = c["track_id"] == i
        if i == ids[0]:
            continue
        if on_mirror[m].mean() >= 0.5:
            n_mirror += 1
            assert c["time"][m].max() <= PINGS[-3]
        else:
            assert np.count_nonzero(m) <= 3
    assert n_mirror == 1


def test_still_clutter_confirms_when_it_enters(tmp_path):
    """The same contacts with every contact allowed to start a track: still scatterers seen
    on consecutive pings are confirmed (what ``moving_only`` prevents)."""
    _nav_, clutter, prod = _files(tmp_path)
    out = str(tmp_path / "tracks.h5")
    run_tracker(prod, _config(tmp_path, moving_only=False), out)
    c = _confirmed(out)
    xy = np.stack([c["x"], c["y"]], 1)
    near = np.linalg.norm(xy[:, None] - clutter[None], axis=-1).min(1) < 300.0
    assert np.unique(c["track_id"][near]).size >= 5


@pytest.mark.parametrize("key", ["time", "ping"])
def test_scan_grouping_key(key, tmp_path):
    """Rows of one ping with distinct reception times form one scan only through ``ping``."""
    _nav_, _cl, prod = _files(tmp_path)
    from arrayproc.io.recording import Recording
    g = read_products(prod)["contacts"]
    c = {k: np.asarray(g[k], float) for k in ("time", "range_m", "bearing_port_deg",
                                             "bearing_stbd_deg", "range_rate_mps")}
    if key == "ping":
        c["ping"] = np.asarray(g["ping"], np.int64)
    with Recording(str(tmp_path / "rec.h5"), require_geometry=False) as r:
        n = len(contact_scans(c, r.nav, False, C))
    assert n == (PINGS.size if key == "ping" else np.unique(c["time"]).size)
