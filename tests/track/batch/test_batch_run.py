"""``run_tma``: products (bearings / delays) + recording /nav → products ``tma``."""

from __future__ import annotations

import numpy as np
import pytest

from arrayproc.errors import ConfigError, FormatError
from arrayproc.io.products import ProductsWriter, read_products
from arrayproc.io.recording import Recording, RecordingWriter
from arrayproc.track.batch import scenarios as S
from arrayproc.track.batch.bo_tma import bearing_model
from arrayproc.track.batch.run import load_tma_config, run_tma
from arrayproc.track.batch.td_tma import delay_model

N_H, DX = 16, 0.75
TRUTH = np.array([2000.0, 1000.0, 0.0, 3.0])


def _recording(path, tr):
    pos = np.zeros((N_H, 3))
    pos[:, 0] = -np.arange(N_H) * DX          # trailing the reference point
    with RecordingWriter(path, 100.0, N_H, positions=pos) as w:
        w.append(np.zeros((10, N_H), np.float32))
        w.set_nav(tr.time, tr.position, np.rad2deg(tr.heading) % 360.0)
    return path


def _setup(tmp_path, seed=0, sig_deg=0.05, sig_tau=2e-5):
    tr = S.turn_track(dt=10.0)
    # nav: the heading changes at the turn; sample finely so that interpolation is exact
    fine = S.turn_track(dt=1.0)
    rec = _recording(tmp_path / "rec.h5", fine)
    with Recording(rec) as r:
        poses = r.poses(tr.time)
    el = np.stack([p.elements[:, :2] for p in poses])
    centre = el.mean(1)
    rng = np.random.default_rng(seed)
    brg = bearing_model(TRUTH, tr.time, centre) + rng.normal(0, np.deg2rad(sig_deg),
                                                             tr.time.size)
    hd = np.deg2rad([p.heading for p in poses])
    rel = (brg - hd + np.pi) % (2 * np.pi) - np.pi
    cone = np.abs(rel)
    tau = delay_model(TRUTH, tr.time, el, 0, 1500.0) + rng.normal(0, sig_tau, (tr.time.size,
                                                                              N_H))
    tau[:, 0] = 0.0
    prod = tmp_path / "prod.h5"
    with ProductsWriter(prod, source=str(rec)) as w:
        g = w.group("bearings", "bearings")
        g.append(time=tr.time, cone_deg=np.rad2deg(cone),
                 bearing_port_deg=np.rad2deg(hd - cone) % 360,
                 bearing_stbd_deg=np.rad2deg(hd + cone) % 360,
                 level_db=np.full(tr.time.size, 90.0), snr_db=np.full(tr.time.size, 20.0),
                 freq_lo=np.full(tr.time.size, 100.0), freq_hi=np.full(tr.time.size, 900.0),
                 spl_db=np.full(tr.time.size, 90.0))
        d = w.group("delays", "delays", reference=0)
        d.append(time=tr.time, tau=tau, sigma=np.full(tau.shape, sig_tau),
                 corr=np.ones(tau.shape))
    return prod, rel


def _cfg(tmp_path, text, name="tma.toml"):
    p = tmp_path / name
    p.write_text("[tma]\n" + text)
    return str(p)


def test_run_bearings_and_delays_within_3_sigma(tmp_path):
    prod, rel = _setup(tmp_path)
    assert np.all(rel > 0)                                     # starboard throughout
    for method, extra in (("bearings", 'sigma_bearing_deg = 0.05\nside = "auto"\n'),
                          ("delays", "")):
        out = tmp_path / f"tma_{method}.h5"
        sols = run_tma(str(prod), _cfg(tmp_path, f'method = "{method}"\n' + extra,
                                       f"{method}.toml"), str(out))
        assert len(sols) == 1
        g = read_products(str(out))["tma"]
        assert g["kind"] == "tma" and g["method"][0] == method.encode()
        est = np.array([g["x"][0], g["y"][0], g["vx"][0], g["vy"][0]])
        sig = np.sqrt(np.diag(g["crlb"][0]))
        assert np.all(np.abs(est - TRUTH) < 3 * sig), (method, est - TRUTH, sig)
        assert g["fim_cond"][0] > 1 and np.isfinite(g["range_sigma_m"][0])
        assert g["heading_deg"][0] == pytest.approx(np.degrees(np.arctan2(est[2], est[3])) % 360)
        if method == "bearings":
            assert sols[0].side == "starboard" and g["cost_mirror"][0] > 10 * g["cost"][0]


def test_run_windows(tmp_path):
    prod, _ = _setup(tmp_path)
    sols = run_tma(str(prod), _cfg(tmp_path, 'method = "bearings"\nwindow = 300.0\n'
                                   'step = 300.0\nsigma_bearing_deg = 0.05\n'),
                   str(tmp_path / "w.h5"))
    assert [(s.t0, s.t1) for s in sols] == [(0.0, 300.0), (300.0, 600.0)]


def test_config_errors(tmp_path):
    with pytest.raises(ConfigError, match="tma.bogus"):
        load_tma_config(_cfg(tmp_path, 'method = "bearings"\nbogus = 1\n'))
    with pytest.raises(ConfigError, match="tma.speed_mps"):
        load_tma_config(_cfg(tmp_path, 'method = "compact"\n'))
    with pytest.raises(ConfigError, match="tma.method"):
        load_tma_config(_cfg(tmp_path, 'method = "kalman"\n'))
    empty = tmp_path / "e.toml"
    empty.write_text("x = 1\n")
    with pytest.raises(ConfigError, match="missing \\[tma\\]"):
        load_tma_config(str(empty))


def test_missing_group(tmp_path):
    rec = _recording(tmp_path / "rec.h5", S.turn_track(dt=10.0))
    prod = tmp_path / "p.h5"
    with ProductsWriter(prod, source=str(rec)) as w:
        w.group("power", "power")
    with pytest.raises(FormatError, match="no bearings group"):
        run_tma(str(prod), _cfg(tmp_path, 'method = "bearings"\n'), str(tmp_path / "o.h5"))
