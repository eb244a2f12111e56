"""The multi-target tracker on line contacts and broadband bearings (``measurements =
"lines+bearings"``), measurement level: sources seen from a towed line array moving north,
each scan a broadband cone row and a line contact per tonal (received frequency
f0 (1 − ṙ / c), noise seeded)."""

from __future__ import annotations

import math
import os

import numpy as np
import pytest

from arrayproc.geo.nav import Nav
from arrayproc.track.multi.config import split_config
from arrayproc.track.multi.lines import KIND_BEARINGS, KIND_LINES, line_scans, track_lines
from arrayproc.track.multi.tonals import NO_FREQ_VAR, TonalBank, tonal_bearing_bank
from arrayproc.track.state import Context

DATA = os.path.join(os.path.dirname(__file__), "..", "..", "..", "arrayproc", "data",
                    "trackers")
C = 1500.0
OWN_V = 2.5  # m/s north


def _cfg(**lines):
    cfg, _ = split_config(os.path.join(DATA, "multi_target.toml"))
    cfg = dict(cfg, measurements="lines+bearings")
    cfg["lines"] = dict(cfg["lines"], **lines)
    return cfg


def _nav(duration: float) -> Nav:
    t = np.arange(0.0, duration + 1.0, 1.0)
    return Nav(t, np.stack([np.zeros_like(t), OWN_V * t], 1), np.zeros_like(t))


def _table(sources, times, seed, sigma_cone=0.5, sigma_hz=0.08, broadband=True, pd_line=1.0):
    """Measurement table (as :func:`~arrayproc.track.multi.lines.line_table`) and the source
    of every row. ``sources``: (x0, y0, vx, vy, tonals); each line detected with probability
    ``pd_line``."""
    rng = np.random.default_rng(seed)
    cols = {k: [] for k in ("time", "cone_deg", "bearing_port_deg", "bearing_stbd_deg",
                            "freq_hz", "snr_db", "kind", "row")}
    label = []
    for t in times:
        for s, (x0, y0, vx, vy, tonals) in enumerate(sources):
            dx, dy = x0 + vx * t, y0 + vy * t - OWN_V * t
            r = math.hypot(dx, dy)
            brg = math.degrees(math.atan2(dx, dy))            # heading 0: cone = |bearing|
            rdot = (dx * vx + dy * (vy - OWN_V)) / r
            kinds = ([KIND_BEARINGS] if broadband else []) + [KIND_LINES] * len(tonals)
            freqs = ([np.nan] if broadband else []) + [f0 * (1 - rdot / C) for f0 in tonals]
            for kind, f in zip(kinds, freqs, strict=True):
                if kind == KIND_LINES and rng.random() >= pd_line:
                    continue
                cone = abs(brg) + rng.normal(0, sigma_cone)
                cols["time"].append(t)
                cols["cone_deg"].append(cone)
                cols["bearing_port_deg"].append((-cone) % 360)
                cols["bearing_stbd_deg"].append(cone % 360)
                cols["freq_hz"].append(f + rng.normal(0, sigma_hz) if np.isfinite(f) else f)
                cols["snr_db"].append(20.0)
                cols["kind"].append(kind)
                cols["row"].append(len(label))
                label.append(s)
    m = {k: np.asarray(v, float) for k, v in cols.items()}
    m["kind"] = m["kind"].astype(np.int64)
    m["row"] = m["row"].astype(np.int64)
    return m, np.array(label)


def _confirmed(tracks):
    return [tr for tr in tracks if tr.confirmed_at is not None]


#: two sources on the starboard side whose bearings cross at t ≈ 333 s (71.6° → 44° and
#: 36.9° → 77°), tonals 150 Hz and 300 Hz
CROSSING = [(3000.0, 1000.0, 0.0, 6.0, [150.0]), (3000.0, 4000.0, 0.0, -3.0, [300.0])]


def _run(sources, seed, duration=600.0, **kw):
    times = np.arange(0.0, duration, 2.0)
    m, label = _table(sources, times, seed, **kw)
    cfg = _cfg()
    tracks = track_lines(line_scans(m, cfg), cfg, _nav(duration))
    return tracks, m, label


def test_crossing_sources_with_different_tonals_stay_two_tracks():
    tracks, m, label = _run(CROSSING, seed=3)
    long = [tr for tr in _confirmed(tracks) if (tr.meta["rows"] >= 0).sum() > 100]
    assert len(long) == 2, [(tr.id, (tr.meta["rows"] >= 0).sum()) for tr in _confirmed(tracks)]
    owners = set()
    for tr in long:
        r = tr.meta["rows"][tr.meta["rows"] >= 0]
        t = m["time"][r]
        src = label[r]
        owner = np.bincount(src).argmax()
        owners.add(int(owner))
        assert np.mean(src == owner) >= 0.98               # no swap at the crossing
        assert t.min() < 250.0 and t.max() > 450.0         # one track through it
        f = tr.meta["f_hz"][-1]
        tonal = CROSSING[owner][4][0]
        assert np.nanmin(np.abs(f - tonal)) < 1.0          # the track holds its own tonal
    assert owners == {0, 1}


def test_broadband_and_line_of_one_source_feed_one_track():
    """The line (detected in 60 % of the scans) updates the track when present (its
    frequency makes it the likelier measurement), the broadband row in the other scans."""
    src = [(2500.0, 2500.0, -2.0, 1.0, [210.0])]
    tracks, m, _ = _run(src, seed=5, duration=300.0, pd_line=0.6)
    conf = _confirmed(tracks)
    assert len(conf) == 1
    r = conf[0].meta["rows"]
    kinds = m["kind"][r[r >= 0]]
    assert (r >= 0).all()                                  # a measurement every scan
    n_lines = int((m["kind"] == KIND_LINES).sum())
    assert (kinds == KIND_LINES).sum() >= 0.95 * n_lines
    assert (kinds == KIND_BEARINGS).sum() > 30
    # every scan's two rows are in the track's gate: no second track is ever started
    assert len(tracks) == 1


def test_two_tonals_of_one_source_are_one_track():
    src = [(2500.0, 2500.0, -2.0, 1.0, [120.0, 333.0])]
    tracks, _m, _ = _run(src, seed=6, duration=300.0)
    conf = _confirmed(tracks)
    assert len(conf) == 1
    f = conf[0].meta["f_hz"][-1]
    got = np.sort(f[np.isfinite(f)])
    assert got.size == 2 and np.allclose(got, [120.0, 333.0], atol=1.0)


def test_tonal_follows_the_doppler_of_an_ownship_turn():
    """Ownship Doppler (module doc of track.multi.tonals): a source dead ahead, the ownship
    going from 0 to 5 m/s towards it, the frequency rises by f v / c = 0.5 Hz; the slot's
    prediction alone (no measurement) follows it."""
    def vel(t):
        return np.stack([np.zeros_like(t), np.clip(np.asarray(t), 0, 10) * 0.5], 1)

    filt = TonalBank(tonal_bearing_bank(0.002), 2, 0.1, 1e-12, 1e9, C, vel)
    x, P = filt.initial(np.array([0.0, 0.0, 0.0, 0.0]), np.eye(4), 150.0, 1e-6)
    X, _ = filt.predict(x[None], P[None], np.array([10.0]), Context(np.zeros(4), t=10.0))
    assert X[0, 4] == pytest.approx(150.0 * (1 + 5.0 / C), rel=1e-9)


def test_frequency_gate_rejects_a_wrong_tonal():
    """A track holding 150 Hz: a line at its bearing and 150.1 Hz is in the gate, one at
    151.5 Hz (10 σ) is not; a broadband row (no frequency) is, with the bearing's
    likelihood alone (S_f = 1/(2π))."""
    from arrayproc.track.manage.associate import gate_threshold, mahalanobis
    from arrayproc.track.manage.mirrored import mirrored_initial

    filt = TonalBank(tonal_bearing_bank(0.002), 3, 0.15, 1e-4, 60.0)
    Z0 = np.array([[60.0, 300.0, 60.0, 150.0, 0.7]])
    xb, Pb, lw = mirrored_initial(Z0, 0, 0.7, 0.2, 0.5)
    x, P = filt.initial(xb, Pb, 150.0, 0.02)
    Z = np.array([[60.2, 299.8, 60.2, 150.1, 0.7], [60.2, 299.8, 60.2, 151.5, 0.7],
                  [60.2, 299.8, 60.2, np.nan, 0.7]])
    nu, S = filt.innovation(x[None], P[None], Z, None, lw[None])
    d2, _ = mahalanobis(nu, S)
    g = gate_threshold(0.999, 2)
    assert d2[0, 0] < g < d2[0, 1] and d2[0, 2] < g
    assert S[0, 2, 1, 1] == pytest.approx(NO_FREQ_VAR)
    # end to end: the two crossing sources with the *same* tonal would be told apart by
    # nothing but bearing; with different tonals the gate keeps each track on its own
    tracks, m, label = _run(CROSSING, seed=3, duration=400.0)
    for tr in _confirmed(tracks):
        r = tr.meta["rows"]
        lines = r[(r >= 0)]
        lines = lines[m["kind"][lines] == KIND_LINES]
        if lines.size > 20:
            assert np.unique(label[lines]).size == 1


def test_same_seed_same_tracks():
    a, _, _ = _run(CROSSING, seed=11, duration=200.0)
    b, _, _ = _run(CROSSING, seed=11, duration=200.0)
    assert len(a) == len(b)
    for ta, tb in zip(a, b, strict=True):
        ha, hb = ta.arrays(), tb.arrays()
        assert np.array_equal(ha["meas"], hb["meas"])
        assert np.array_equal(ha["x"], hb["x"], equal_nan=True)


def test_products_without_lines_are_tracked_as_bearings(tmp_path):
    """The shipped tracker (lines+bearings) on products without a lines group: a warning, and
    the tracks of ``measurements = "bearings"`` bit for bit."""
    from arrayproc.io.products import ProductsWriter, read_products
    from arrayproc.track.runner import run_tracker
    from tests.track.test_runner import _write_inputs

    rec, full, _ = _write_inputs(tmp_path)
    g = read_products(str(full))["bearings"]
    keep = np.asarray(g["time"]) < 400.0                   # a short run: the first 400 s
    prod = tmp_path / "short.h5"
    with ProductsWriter(prod, source=str(rec)) as w:
        w.group("bearings", "bearings").append(**{k: np.asarray(g[k])[keep] for k in g
                                                  if k not in ("kind", "stage", "attrs")})
    shipped = os.path.join(DATA, "multi_target.toml")
    text = open(shipped, encoding="utf-8").read()
    assert 'measurements = "lines+bearings"' in text
    only = tmp_path / "bearings.toml"
    only.write_text(text.replace('measurements = "lines+bearings"', 'measurements = "bearings"'))
    with pytest.warns(UserWarning, match="no lines group"):
        run_tracker(str(prod), shipped, str(tmp_path / "a.h5"))
    run_tracker(str(prod), str(only), str(tmp_path / "b.h5"))
    a, b = read_products(str(tmp_path / "a.h5"))["tracks"], \
        read_products(str(tmp_path / "b.h5"))["tracks"]
    assert a["time"].size > 0 and set(a) == set(b)
    for k in ("time", "track_id", "x", "y", "cov", "status", "row"):
        assert np.array_equal(np.asarray(a[k]), np.asarray(b[k]), equal_nan=True), k


def _drop(m, label, keep):
    return {k: v[keep] for k, v in m.items()}, label[keep]


def _track_table(m, label, duration):
    """Track a table whose rows were thinned; every 2 s snapshot is a scan, rows or none."""
    cfg = _cfg()
    m = dict(m, row=np.arange(m["time"].size))
    scans = line_scans(m, cfg, np.arange(0.0, duration, 2.0))
    return track_lines(scans, cfg, _nav(duration)), m


@pytest.mark.parametrize("same_tonal", [True, False])
def test_a_source_whose_lines_fade_keeps_its_track(same_tonal):
    """Lines only, gone for 60 s (longer than a track coasts): the track that resumes with the
    same tonal is the same track (stitched by its tonal); with another tonal it is another."""
    src = [(2500.0, 2500.0, -2.0, 1.0, [210.0])]
    times = np.arange(0.0, 400.0, 2.0)
    m, label = _table(src, times, seed=8, broadband=False)
    m, label = _drop(m, label, (m["time"] < 150.0) | (m["time"] >= 210.0))
    if not same_tonal:
        m["freq_hz"] = np.where(m["time"] >= 210.0, m["freq_hz"] + 40.0, m["freq_hz"])
    tracks, m = _track_table(m, label, 400.0)
    conf = [tr for tr in _confirmed(tracks) if (tr.meta["rows"] >= 0).sum() > 30]
    spans = sorted((m["time"][tr.meta["rows"][tr.meta["rows"] >= 0]].min(),
                    m["time"][tr.meta["rows"][tr.meta["rows"] >= 0]].max()) for tr in conf)
    if same_tonal:
        assert len(conf) == 1 and spans[0][0] < 20.0 and spans[0][1] > 380.0, spans
    else:
        assert len(conf) == 2 and spans[0][1] < 150.0 and spans[1][0] >= 210.0, spans


def test_a_tonal_source_crossing_a_broadband_one_stays_two_tracks():
    """One source seen only in the broadband, one only by its line, crossing in bearing: a
    track with tonals and one without are not duplicates while they cross."""
    times = np.arange(0.0, 600.0, 2.0)
    a, la = _table([CROSSING[0]], times, seed=12)
    b, lb = _table([CROSSING[1]], times, seed=13)
    a, la = _drop(a, la, a["kind"] == KIND_BEARINGS)                 # broadband only
    b, lb = _drop(b, lb + 1, b["kind"] == KIND_LINES)                 # its line only
    m = {k: np.concatenate([a[k], b[k]]) for k in a}
    label = np.concatenate([la, lb])
    tracks, m = _track_table(m, label, 600.0)
    long = [tr for tr in _confirmed(tracks) if (tr.meta["rows"] >= 0).sum() > 100]
    assert len(long) == 2
    for tr in long:
        r = tr.meta["rows"][tr.meta["rows"] >= 0]
        src = label[r]
        assert np.mean(src == np.bincount(src).argmax()) >= 0.95
        assert m["time"][r].min() < 250.0 and m["time"][r].max() > 450.0
