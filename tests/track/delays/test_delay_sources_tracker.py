"""Several sources' TDOA tracks (:mod:`arrayproc.track.delays.sources`): with one row per
scan it is the one-source tracker bit for bit; with two sources' rows per scan, in any order,
two confirmed tracks, each on its source; ``arrayproc track`` picks it for such a product."""

from __future__ import annotations

import numpy as np
import pytest

from arrayproc.errors import ConfigError
from arrayproc.geo.tdoa import predicted_delays
from arrayproc.track.batch import scenarios as S
from arrayproc.track.delays import check_delays_config, track_delay_sources, track_delays

N_H, DX, C = 21, 1.0, 1500.0
SOURCES = np.array([[2500.0, 1500.0], [-1800.0, 2600.0]])


def _geometry(dt=10.0):
    tr = S.turn_track(dt=dt)
    el2 = S.line_elements(tr, N_H, DX)
    el = np.concatenate([el2, np.full(el2.shape[:2] + (1,), 50.0)], axis=-1)
    return tr, el


def _delays(el, xy):
    s = np.r_[xy, 50.0]
    return np.stack([predicted_delays(s, el[b], 0, C) for b in range(el.shape[0])])


@pytest.mark.parametrize("d", [{"motion": "static", "range_bank": [1000.0, 20000.0, 6]},
                               {"motion": "cv", "range_m": 6000.0, "sigma_range_m": 4000.0}])
def test_one_source_rows_give_the_one_source_track_bit_for_bit(d):
    tr, el = _geometry()
    rng = np.random.default_rng(3)
    tau = _delays(el, SOURCES[0]) + rng.normal(0, 2e-6, (el.shape[0], N_H))
    tau[:, 0] = 0.0
    tau[5, 3:] = np.nan            # a row with fewer delays
    tau[7, 2:] = np.nan            # a coast
    sig = np.full(tau.shape, 2e-6)
    vel = 3.0 * np.stack([np.sin(tr.heading), np.cos(tr.heading)], -1)
    a = track_delays(tr.time, tau, sig, el, 0, C, d, "ukf", heading_rad=tr.heading,
                     array_velocity=vel)
    b = track_delay_sources(tr.time, tau, sig, el, 0, C, d, "ukf", heading_rad=tr.heading,
                            array_velocity=vel)
    for k in a:
        assert np.asarray(a[k]).tobytes() == np.asarray(b[k]).tobytes(), k
    assert set(b["track_id"]) == {1} and set(b["status"]) == {"confirmed"}


def test_two_sources_two_tracks_whatever_the_row_order():
    tr, el = _geometry()
    B = el.shape[0]
    rng = np.random.default_rng(5)
    tau2 = np.stack([_delays(el, s) for s in SOURCES], 1)            # (B, 2, N)
    # arrival-time noise per hydrophone (σ/√2 each: the delays' common-reference model)
    e = rng.normal(0, 1e-5 / np.sqrt(2), tau2.shape)
    tau2 += e - e[..., :1]
    swap = rng.uniform(size=B) < 0.5                                 # rows in random order
    tau2[swap] = tau2[swap, ::-1]
    tau = tau2.reshape(2 * B, N_H)
    t = np.repeat(tr.time, 2)
    el_r = np.repeat(el, 2, axis=0)
    d = {"motion": "static", "range_bank": [1000.0, 20000.0, 6], "gate_prob": 0.9999,
         "confirm": [3, 5], "max_misses": 5, "side": "auto"}
    r = track_delay_sources(t, tau, np.full(tau.shape, 1e-5), el_r, 0, C, d, "ukf",
                            heading_rad=np.repeat(tr.heading, 2))
    ids = r["track_id"]
    conf = np.unique(ids[r["status"] == "confirmed"])
    assert conf.size == 2 and np.unique(ids).size == 2
    assert r["updated"].all()                                         # every row used
    for i in conf:
        last = np.flatnonzero(ids == i)[-1]
        err = np.hypot(SOURCES[:, 0] - r["x"][last], SOURCES[:, 1] - r["y"][last])
        assert err.min() < 30.0                                       # m, at 2-3 km
    finals = [np.argmin(np.hypot(SOURCES[:, 0] - r["x"][np.flatnonzero(ids == i)[-1]],
                                 SOURCES[:, 1] - r["y"][np.flatnonzero(ids == i)[-1]]))
              for i in conf]
    assert sorted(finals) == [0, 1]
    # every row assigned to one track at most, each scan at most one row per track
    upd = r["updated"]
    pairs = set(zip(r["time"][upd].tolist(), ids[upd].tolist(), strict=True))
    assert len(pairs) == int(upd.sum())


def test_confirm_key_is_checked():
    with pytest.raises(ConfigError, match="confirm"):
        check_delays_config({"type": "delays", "delays": {"confirm": [3, 2]}}, "t.toml")
    with pytest.raises(ConfigError, match="max_misses"):
        check_delays_config({"type": "delays", "delays": {"max_misses": -1}}, "t.toml")


def test_arrayproc_track_on_two_sources_delays(tmp_path):
    """A ``delays`` product with two rows per time (``tde`` peaks > 1) + the recording's /nav
    → ``arrayproc track`` writes two confirmed tracks, one on each source."""
    from arrayproc.io.products import ProductsWriter, read_products
    from arrayproc.io.recording import RecordingWriter
    from arrayproc.track.runner import run_tracker

    fine = S.turn_track(dt=1.0)
    pos = np.zeros((N_H, 3))
    pos[:, 0] = -np.arange(N_H) * DX
    rec = tmp_path / "rec.h5"
    with RecordingWriter(rec, 100.0, N_H, positions=pos) as w:
        w.append(np.zeros((10, N_H), np.float32))
        w.set_nav(fine.time, fine.position, np.rad2deg(fine.heading) % 360.0)
    tr, el = _geometry()
    el[..., 2] = 0.0
    tau2 = np.stack([np.stack([predicted_delays(np.r_[s, 0.0], el[b], 0, C)
                               for b in range(el.shape[0])]) for s in SOURCES], 1)
    prod = tmp_path / "del.h5"
    with ProductsWriter(prod, source=str(rec)) as w:
        g = w.group("tde", "delays", reference=0)
        g.append(time=np.repeat(tr.time, 2), tau=tau2.reshape(-1, N_H),
                 sigma=np.full((2 * tr.time.size, N_H), 1e-5),
                 corr=np.ones((2 * tr.time.size, N_H)),
                 source=np.tile([0, 1], tr.time.size), closure=np.ones(2 * tr.time.size))
    cfg = tmp_path / "trk.toml"
    cfg.write_text('[tracker]\ntype = "delays"\nfilter = "ukf"\n[tracker.delays]\n'
                   'range_bank = [1000.0, 20000.0, 6]\ngate_prob = 0.9999\nconfirm = [3, 5]\n'
                   'max_misses = 5\narray_motion = false\n')
    out = tmp_path / "trk.h5"
    run_tracker(str(prod), str(cfg), str(out))
    g = read_products(str(out))["tracks"]
    ids = np.asarray(g["track_id"])
    conf = np.unique(ids[np.asarray(g["status"]) == 1])
    assert conf.size == 2
    ends = [np.flatnonzero(ids == i)[-1] for i in conf]
    err = np.hypot(SOURCES[:, 0][:, None] - g["x"][ends], SOURCES[:, 1][:, None] - g["y"][ends])
    assert sorted(np.argmin(err, axis=0)) == [0, 1] and err.min(axis=0).max() < 30.0
