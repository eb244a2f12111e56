"""Multi mode end to end on synthetic towed-array bearings: two sources (P_D 0.85), 0.3
clutter rows per scan, an ownship turn; each source held by one confirmed track, L-R
resolved, the metrics agree; the mirrored hypotheses coast through a turn."""

from __future__ import annotations

import math

import numpy as np
import pytest

from arrayproc.errors import ConfigError
from arrayproc.evaluate.metrics import evaluate_tracks_file
from arrayproc.io.products import ProductsWriter, read_products
from arrayproc.io.recording import RecordingWriter
from arrayproc.track.manage.mirrored import mirrored_bank, mirrored_cone, mirrored_initial
from arrayproc.track.manage.tracks import status_names
from arrayproc.track.multi import bearing_scans, split_config
from arrayproc.track.runner import run_tracker
from arrayproc.track.state import Context

CFG = """
[tracker]
mode = "multi"
filter = "ukf"
lr = true
sigma_bearing_deg = 1.0
range_m = 3000.0
sigma_range_m = 1500.0
speed_mps = 4.0
sigma_speed_mps = 3.0
q1 = 1.0e-4
confirm = [3, 5]
max_misses = 15
[tracker.bearing]
space = "{space}"
"""


def _ownship(t):
    """East at 2.5 m/s for 200 s, 1°/s turn to 150°, then straight."""
    h = np.where(t < 200, 90.0, np.minimum(90.0 + (t - 200), 150.0))
    pos = np.zeros((t.size, 2))
    for k in range(1, t.size):
        a = math.radians(h[k - 1])
        pos[k] = pos[k - 1] + 2.5 * (t[k] - t[k - 1]) * np.array([math.sin(a), math.cos(a)])
    return pos, h


def _write(tmp_path, seed=0, gap=True):
    rng = np.random.default_rng(seed)
    tn = np.arange(0.0, 401.0, 1.0)
    pos, hd = _ownship(tn)
    rec = tmp_path / "rec.h5"
    with RecordingWriter(rec, 100.0, 2, positions=np.array([[0.0, 0, 0], [0.75, 0, 0]]),
                         start_time="2026-01-01T00:00:00Z") as w:
        w.append(np.zeros((100, 2), np.float32))
        w.set_nav(tn, pos, hd)
    src = {"north": (np.array([-1500.0, 2600.0]), np.array([5.0, -0.5])),
           "south": (np.array([2500.0, -3000.0]), np.array([-2.0, 1.5]))}
    t = np.arange(1.0, 400.0, 2.0)
    cols = {k: [] for k in ("time", "cone_deg", "bearing_port_deg", "bearing_stbd_deg",
                            "level_db", "snr_db", "freq_lo", "freq_hi", "spl_db")}
    truth_pos = {}
    for name, (p0, v) in src.items():
        truth_pos[name] = p0[None] + t[:, None] * v[None]
    for k, tk in enumerate(t):
        o = np.array([np.interp(tk, tn, pos[:, i]) for i in range(2)])
        h = float(np.interp(tk, tn, hd))
        rows = []
        for name in src:
            if rng.random() > 0.85:
                continue
            if gap and name == "north" and 205 < tk < 232:
                continue  # fades during the turn
            d = truth_pos[name][k] - o
            b = math.degrees(math.atan2(d[0], d[1]))
            cone = abs((b - h + 180) % 360 - 180) + 0.5 * rng.standard_normal()
            rows.append(cone)
        if rng.random() < 0.3:
            rows.append(rng.uniform(20, 170))  # clutter: 0.3 rows per scan
        for cone in rows:
            cols["time"].append(tk)
            cols["cone_deg"].append(cone)
            cols["bearing_port_deg"].append((h - cone) % 360)
            cols["bearing_stbd_deg"].append((h + cone) % 360)
            for c in ("level_db", "snr_db", "spl_db"):
                cols[c].append(10.0)
            cols["freq_lo"].append(60.0)
            cols["freq_hi"].append(900.0)
    prod = tmp_path / "prod.h5"
    with ProductsWriter(prod, source=str(rec)) as w:
        w.group("bearings", "bearings").append(**{k: np.array(v) for k, v in cols.items()})
    with h5_truth(rec) as f:
        for name in src:
            g = f.create_group(f"truth/sources/{name}")
            g.create_dataset("time", data=t)
            g.create_dataset("position", data=truth_pos[name])
            g.attrs["kind"] = "source"
    return str(prod)


def h5_truth(path):
    import h5py
    return h5py.File(path, "a")


@pytest.mark.parametrize("space", ["bearing", "cone"])
def test_two_sources_one_track_each(tmp_path, space):
    prod = _write(tmp_path, gap=False)
    cfg = tmp_path / "multi.toml"
    cfg.write_text(CFG.format(space=space))
    out = tmp_path / "tracks.h5"
    run_tracker(prod, str(cfg), str(out))
    r = evaluate_tracks_file(str(out), detect_gate_deg=2.0)
    assert np.all(r["held"] >= 0.9), r["held"]
    assert len(r["false_tracks"]) <= 1
    g = read_products(str(out))["tracks"]
    st = status_names(g["status"])
    assert set(st) <= {"tentative", "confirmed", "deleted"}
    # after the turn the L-R weight of the principal tracks has resolved
    for tid in r["principal"]:
        m = (g["track_id"] == tid) & (g["time"] > 330)
        assert np.all(np.abs(g["side_weight"][m] - 0.5) > 0.45)


def test_mirrored_hypotheses_coast_through_a_turn():
    """A target fixed at true bearing 30° (starboard, cone 60° at heading 330°): 20 scans of
    updates, then 15 coasted scans while the array turns 30°; the starboard hypothesis still
    predicts the true bearing (its cone has moved by the turn), so the target's next
    measurement falls inside its gate."""
    f = mirrored_bank(q=0.002, sigma_cone_deg=0.5)
    h, b = 330.0, 30.0

    def z(h):
        cone = abs((b - h + 180) % 360 - 180)
        return np.array([[cone, (h - cone) % 360, (h + cone) % 360]])

    x, P, w = mirrored_initial(z(h), 0, 0.5, 0.2, 0.5)
    X, P, W = x[None], P[None], w[None]
    for _ in range(20):
        X, P = f.predict(X, P, np.array([2.0]), Context(np.zeros(4)))
        X, P, _, W = f.update(X, P, z(h), None, np.array([0]), W)
    for _ in range(15):  # coasting through a 2°/s turn
        h += 2.0
        X, P = f.predict(X, P, np.array([2.0]), Context(np.zeros(4), q_scale=1.0 + 4.0))
    nu, S = f.innovation(X, P, z(h), None, W)
    assert nu[0, 0, 0] ** 2 / S[0, 0, 0, 0] < 9.0
    cone, _, _ = mirrored_cone(f, X, P, W, np.array([h]))
    assert X[0, 0] == pytest.approx(b, abs=1.0)


def test_mirrored_filter_weights_and_cone():
    f = mirrored_bank(q=0.002, sigma_cone_deg=0.5)
    Z = np.array([[60.0, 30.0, 150.0]])  # heading 90: port 30, starboard 150
    x, P, w = mirrored_initial(Z, 0, 0.5, 0.2, 0.5)
    X, P, W = x[None], P[None], w[None]
    # after a turn to heading 120 the target (truly to starboard, bearing 150) is at cone 30:
    # starboard member 150, port member 90
    X, P = f.predict(X, P, np.array([10.0]), Context(np.zeros(4)))
    X, P, _, W = f.update(X, P, np.array([[30.0, 90.0, 150.0]]), None, np.array([0]), W)
    w = np.exp(W[0])
    assert w[0] > 0.99 and abs(w.sum() - 1) < 1e-8  # ghost floored at 1e-9
    cone, sig, ws = mirrored_cone(f, X, P, W, np.array([120.0]))
    assert cone[0] == pytest.approx(30.0, abs=0.5) and ws[0] > 0.99 and sig[0] < 1.0
    nu, S = f.innovation(X, P, np.array([[31.0, 89.0, 151.0]]), None, W)
    assert nu.shape == (1, 1, 1) and nu[0, 0, 0] == pytest.approx(151.0 - X[0, 0])


def test_bearing_scans_merge_rows():
    t = np.array([1.0, 1.0, 1.0, 2.0])
    cone = np.array([50.0, 52.0, 90.0, 50.0])
    score = np.array([3.0, 9.0, 1.0, 1.0])
    sc = bearing_scans(t, cone, score, 4.0)
    assert [s[0] for s in sc] == [1.0, 2.0]
    assert list(sc[0][2]) == [1, 2]  # the stronger of the merged pair, then the lone row


def test_config_errors(tmp_path):
    p = tmp_path / "c.toml"
    for text, key in (('mode = "multi"\nconfirm = [4, 3]', "confirm"),
                      ('mode = "multi"\nassociation = "mht"', "association"),
                      ('mode = "multi"\n[tracker.bearing]\nspace = "x"', "space"),
                      ('mode = "multi"\n[tracker.bearing]\nfoo = 1', "foo"),
                      ('mode = "multi"\nfilter = "nope"', "filter")):
        p.write_text("[tracker]\n" + text + "\n")
        with pytest.raises(ConfigError, match=key):
            split_config(str(p))


def test_contacts_mode_end_to_end(tmp_path):
    from .conftest import contact_files
    _rec, prod, final = contact_files(tmp_path)
    cfg = tmp_path / "c.toml"
    cfg.write_text('[tracker]\nmode = "multi"\nmeasurements = "contacts"\n[tracker.contacts]\n'
                   'sigma_bearing_deg = 1.0\nsigma_range_m = 15.0\nsigma_range_rate_mps = 0.2\n')
    out = tmp_path / "t.h5"
    run_tracker(prod, str(cfg), str(out))
    g = read_products(str(out))["tracks"]
    st = status_names(g["status"])
    ends = []
    for tid in np.unique(g["track_id"][st == "confirmed"]):
        last = np.flatnonzero((g["track_id"] == tid) & (st == "confirmed"))[-1]
        ends.append([g["x"][last], g["y"][last]])
    assert len(ends) == 2
    d = np.linalg.norm(np.array(ends)[:, None] - final[None], axis=-1)
    assert d.min(1).max() < 100.0
