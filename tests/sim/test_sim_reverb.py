"""Reverberation (Lambert scatterers) against the sonar equation, bottom features and
extended (multi-highlight) targets."""

from __future__ import annotations

import numpy as np
import pytest

from arrayproc.errors import ConfigError
from arrayproc.evaluate.scenarios.realism import FS, C, sonar_equation_intensity
from arrayproc.evaluate.scenarios.realism import active_scenario as active
from arrayproc.sim.run import Simulator
from arrayproc.sim.scenario import parse_scenario


def test_reverberation_level_against_the_sonar_equation():
    depth, zr, mu_db, pulse, half = 100.0, 20.0, -27.0, 0.01, 700.0
    rv = {"boundary": "bottom", "depth": depth, "scattering_strength_db": mu_db,
          "density": 0.002, "area": [-half, half, -half, half]}
    dur = 0.1 + 2 * 650.0 / C + 0.05
    p2 = []
    for seed in range(8):
        sim = Simulator(parse_scenario(active({"reverberation": [rv]}, dur, seed, pulse, zr)))
        x = sim.render(0, sim.n_samples)[:, 0].astype(float)
        p2.append(x**2)
    p2 = np.mean(p2, axis=0)
    t = np.arange(p2.size) / FS - 0.1  # time since the ping
    cf = sonar_equation_intensity(t, 200.0, mu_db, depth, zr, pulse)
    edges = np.arange(0.2, 2 * 640.0 / C, 0.1)
    rows = []
    for a, b in zip(edges[:-1], edges[1:]):
        m = (t >= a) & (t < b)
        rows.append((0.5 * (a + b), 10 * np.log10(p2[m].mean() / cf[m].mean())))
    err = np.array([e for _, e in rows])
    sl_n = len(sim.active.scatterers)
    print(f"bottom reverberation ({sl_n} Lambert scatterers, μ = {mu_db} dB, 8 seeds): "
          "sim − sonar equation per 0.1 s bin (dB): "
          + ", ".join(f"{tc:.2f} s {e:+.2f}" for tc, e in rows))
    assert np.all(np.abs(err) < 1.0)
    assert abs(np.mean(err)) < 0.3
    # truth lists the scatterers but no reverberation echo rows
    g, _ = sim.truth()
    assert g["echoes"]["ping"].size == 0
    assert (g["scatterers"]["kind"] == b"reverb").sum() == sl_n


def test_extended_target_highlights_keep_the_total_strength():
    """A 40 m target pointing at the sonar, 5 highlights: 5 echoes 2·10 m/c apart whose total
    energy equals a point target's of the same TS (incoherent split)."""
    r0 = 400.0
    tgt = {"name": "sub", "start": [0.0, r0], "depth": 20.0, "heading": 180.0, "ts_db": 10.0}
    dur = 0.1 + 2 * (r0 + 30.0) / C
    ext = Simulator(parse_scenario(active({"target": [dict(tgt, length=40.0, highlights=5)]},
                                          dur, pulse=0.005)))
    pt = Simulator(parse_scenario(active({"target": [tgt]}, dur, pulse=0.005)))
    xe = ext.render(0, ext.n_samples)[:, 0].astype(float)
    xp = pt.render(0, pt.n_samples)[:, 0].astype(float)
    g, _ = ext.truth()
    delays = np.sort(g["echoes"]["delay_s"])
    e_ratio = 10 * np.log10(np.sum(xe**2) / np.sum(xp**2))
    # each highlight's range differs, so its spreading differs: predicted energy ratio
    r = r0 + np.linspace(-20.0, 20.0, 5)
    pred = 10 * np.log10(np.mean(r0**4 / r**4))
    print(f"extended target: echo delays {np.round(delays * 1e3, 2)} ms (spacing "
          f"{np.diff(delays).mean() * 1e3:.2f} ms, 2·10 m/c = {20 / C * 1e3:.2f} ms); energy "
          f"{e_ratio:+.3f} dB re point target (predicted {pred:+.3f} dB)")
    assert (g["scatterers"]["kind"] == b"highlight").sum() == 5
    np.testing.assert_allclose(np.diff(delays), 20.0 / C, rtol=1e-3)
    assert abs(e_ratio - pred) < 0.1


def test_ridge_feature_gives_static_echoes_at_its_points():
    ridge = {"name": "ridge", "line": [[-200.0, 300.0], [200.0, 300.0]], "count": 9,
             "depth": 80.0, "ts_db": 0.0}
    dur = 0.1 + 2 * 400.0 / C
    sim = Simulator(parse_scenario(active({"feature": [ridge]}, dur)))
    g, _ = sim.truth()
    pos = g["scatterers"]["position0"]
    assert pos.shape == (9, 3) and np.allclose(pos[:, 1], 300.0) and np.allclose(pos[:, 2], 80.0)
    want = 2 * np.linalg.norm(pos - [0.0, 0.0, 20.0], axis=1) / C
    np.testing.assert_allclose(np.sort(g["echoes"]["delay_s"]), np.sort(want), rtol=1e-9)
    x = sim.render(0, sim.n_samples)[:, 0]
    assert np.abs(x).max() > 0


def test_reverberation_keys_are_checked():
    with pytest.raises(ConfigError, match="depth"):
        parse_scenario(active({"reverberation": [{"boundary": "bottom",
                                                  "scattering_strength_db": -27.0,
                                                  "density": 0.01,
                                                  "area": [0.0, 10.0, 0.0, 10.0]}]}, 1.0))
    with pytest.raises(ConfigError, match="at most"):
        parse_scenario(active({"reverberation": [{"boundary": "surface",
                                                  "scattering_strength_db": -40.0,
                                                  "density": 1.0,
                                                  "area": [-1e4, 1e4, -1e4, 1e4]}]}, 1.0))
    with pytest.raises(ConfigError, match="position"):
        parse_scenario(active({"feature": [{"depth": 10.0, "ts_db": 0.0}]}, 1.0))


def test_drifting_clutter_has_the_closed_form_radial_speeds():
    """Clutter with drift_speed_std σ: each echo's truth range rate is the point's radial
    speed, N(0, σ²) along any line of sight, so |ṙ| < 2 kn with probability erf(u/(σ√2));
    the echo itself is time-scaled by that range rate (its arrival moves between pings)."""
    from math import erf, sqrt

    sigma, n = 1.0, 400
    cl = {"count": n, "area": [-800.0, 800.0, -800.0, 800.0], "depth": 50.0,
          "drift_speed_std": sigma}
    dur = 0.1 + 2 * 1200.0 / C  # every echo (farthest point 1131 m) arrives
    sim = Simulator(parse_scenario(active({"clutter": cl}, dur, seed=3)))
    g, _ = sim.truth()
    e = g["echoes"]
    rr = e["range_rate_mps"][g["scatterers"]["kind"][e["target"]] == b"clutter"]
    assert rr.size == n
    u = 2.0 * 1852.0 / 3600.0
    # 400 draws: the std to ~3.5 % (1σ), the static share to ~2.3 % (1σ)
    assert np.std(rr) == pytest.approx(sigma, rel=0.15)
    assert np.mean(np.abs(rr) < u) == pytest.approx(erf(u / (sigma * sqrt(2.0))), abs=0.08)
    # static clutter: every range rate 0 (the same seed's positions)
    static = Simulator(parse_scenario(active({"clutter": dict(cl, drift_speed_std=0.0)}, dur,
                                             seed=3)))
    gs, _ = static.truth()
    assert np.all(gs["echoes"]["range_rate_mps"] == 0.0)
    assert np.array_equal(gs["scatterers"]["position0"], g["scatterers"]["position0"])
