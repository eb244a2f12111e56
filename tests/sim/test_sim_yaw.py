"""Gauss-Markov heading jitter of a rigid array (``[array] yaw_std``, ``yaw_time``): off by
default (the recording unchanged), stationary statistics with the correlation time asked for,
the elements turned by ψ(t) while ``/nav`` keeps the nominal heading."""

from __future__ import annotations

import copy

import h5py
import numpy as np
import pytest

from arrayproc.errors import ConfigError
from arrayproc.sim.run import Simulator, simulate
from arrayproc.sim.scenario import parse_scenario
from arrayproc.sim.yaw import GaussMarkovYaw

BASE = {
    "recording": {"fs": 2000.0, "duration": 4.0, "seed": 3, "chunk": 1500},
    "array": {"type": "tetrahedron", "side": 1.84, "depth": 50.0},
    "ownship": {"start": [0.0, 0.0], "heading": 30.0},
    "source": [{"name": "v", "start": [-200.0, 150.0], "depth": 4.0, "course": 90.0,
                "speed": 7.3, "broadband": {"band": [100.0, 800.0], "level_db": 120.0}}],
    "noise": {"level_db": 50.0},
}


def scen(**array):
    d = copy.deepcopy(BASE)
    d["array"].update(array)
    return parse_scenario(d, "yaw.toml")


def _datasets(path):
    out = {}
    with h5py.File(path, "r") as f:
        f.visititems(lambda n, o: out.__setitem__(n, o[()]) if isinstance(o, h5py.Dataset)
                     else None)
    return out


def test_default_off_is_unchanged(tmp_path):
    a = _datasets(simulate(scen(), tmp_path / "a.h5"))
    b = _datasets(simulate(scen(yaw_std=0.0, yaw_time=5.0), tmp_path / "b.h5"))
    assert a.keys() == b.keys()
    assert all(np.array_equal(a[k], b[k]) for k in a)
    assert "truth/array/yaw_deg" not in a


def test_jitter_turns_the_elements_not_the_nav(tmp_path):
    path = simulate(scen(yaw_std=2.0, yaw_time=1.0), tmp_path / "y.h5")
    plain = _datasets(simulate(scen(), tmp_path / "p.h5"))
    d = _datasets(path)
    assert not np.array_equal(d["time_data"], plain["time_data"])
    assert np.array_equal(d["nav/heading"], plain["nav/heading"])
    sim = Simulator(scen(yaw_std=2.0, yaw_time=1.0))
    ref = Simulator(scen())
    t = 2.345
    psi = float(np.interp(t, d["truth/array/yaw_time"], d["truth/array/yaw_deg"]))
    assert abs(psi) > 0.05
    # the element offsets of the jittered array are the nominal ones turned by ψ (clockwise)
    e, e0 = sim.element_positions(t), ref.element_positions(t)
    c = e[:, :2] - e[:, :2].mean(0)
    c0 = e0[:, :2] - e0[:, :2].mean(0)
    off = np.hypot(*c0.T) > 0.1  # the apex lies over the centroid: no direction
    assert off.sum() == 3
    ang = np.degrees(np.arctan2(c[off, 0], c[off, 1]) - np.arctan2(c0[off, 0], c0[off, 1]))
    assert np.allclose((ang + 180) % 360 - 180, psi, atol=1e-9)


def test_render_chunk_independent_with_jitter():
    sim = Simulator(scen(yaw_std=1.0, yaw_time=0.5))
    whole = sim.render(0, 6000)
    parts = np.concatenate([sim.render(0, 1234), sim.render(1234, 6000)])
    assert np.array_equal(whole, parts)


def test_yaw_statistics():
    """Stationary from t = 0: var σ², correlation exp(−Δ/τ) at Δ = τ (100 records)."""
    sig, tau = 1.5, 20.0
    t = np.arange(0.0, 400.0, 1.0)
    y = np.stack([GaussMarkovYaw(sig, tau, 400.0, np.random.SeedSequence(s))(t)
                  for s in range(100)])
    assert np.var(y[:, 0]) == pytest.approx(sig**2, rel=0.3)
    assert np.var(y) == pytest.approx(sig**2, rel=0.1)
    lag = int(tau)
    rho = np.mean(y[:, :-lag] * y[:, lag:]) / np.mean(y * y)
    assert rho == pytest.approx(np.exp(-1.0), abs=0.06)


def test_water_pulled_refused():
    d = copy.deepcopy(BASE)
    d["array"] = {"type": "line", "n": 4, "spacing": 1.0, "shape": "water_pulled",
                  "yaw_std": 1.0}
    d["ownship"] = {"start": [0.0, 0.0], "course": 0.0, "speed": 2.0}
    with pytest.raises(ConfigError, match="yaw_std"):
        parse_scenario(d, "yaw.toml")
