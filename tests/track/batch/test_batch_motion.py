"""The array's and the source's motion during propagation (arrayproc.track.batch.motion):
closed forms, the simulator's rendering, and the difference the corrections make to `tma`."""

from __future__ import annotations

import numpy as np
import pytest

from arrayproc.app.commands import process, simulate
from arrayproc.io.products import read_products
from arrayproc.io.recording import Recording
from arrayproc.track.batch.motion import (
    axial_speed,
    emission_points,
    nav_velocity,
    static_cone,
    static_delays,
)

C = 1500.0


def _emission_closed_form(p_rx, v, obs, c):
    """s = t_rx − t_e > 0 from |p_rx − v s − o| = c s (a quadratic in s)."""
    g = p_rx - obs
    a = v @ v - c * c
    b = -2.0 * (g @ v)
    q = g @ g
    return (-b - np.sqrt(b * b - 4 * a * q)) / (2 * a)


def test_emission_points_solve_the_light_cone():
    """eq. (M5) against the exact root of |p0 + v t_e − o| = c (t − t_e), to the fixed-point
    iteration's error R (|v|/c)^(N+1) (N = 2 updates)."""
    rng = np.random.default_rng(0)
    tau = np.linspace(0.0, 600.0, 31)
    obs = rng.uniform(-100, 100, (tau.size, 2))
    for _ in range(20):
        x = np.r_[rng.uniform(-15e3, 15e3, 2), rng.uniform(-12, 12, 2)]
        p_e, tau_e = emission_points(x, tau, obs, C)
        spd = np.hypot(*x[2:])
        for b in range(tau.size):
            s = _emission_closed_form(x[:2] + x[2:] * tau[b], x[2:], obs[b], C)
            bound = C * s * (spd / C) ** 3
            assert np.hypot(*(p_e[b] - (x[:2] + x[2:] * (tau[b] - s)))) <= bound
            assert abs(tau_e[b] - (tau[b] - s)) * spd <= bound
    # at 15 km and 10 m/s the position error is below 2 cm
    x = np.array([15e3, 0.0, 0.0, 10.0])
    s = _emission_closed_form(x[:2], x[2:], np.zeros(2), C)
    p_e = emission_points(x, np.zeros(1), np.zeros((1, 2)), C)[0][0]
    assert np.hypot(*(p_e - (x[:2] - x[2:] * s))) < 0.02


def test_moving_line_array_closed_form():
    """Exact arrivals at a line array moving along its axis (each element's arrival solves a
    quadratic light-cone equation) against the static delays: the measured delays are the
    static ones divided by 1 + (v/c) cos θ (M1), the apparent cone obeys (M3); the
    corrections (M2), (M4) remove the difference to far below it."""
    n, dx, v = 32, 0.75, 3.0
    heading = np.deg2rad(20.0)
    a = np.array([np.sin(heading), np.cos(heading)])
    body = -np.arange(n) * dx                                  # trailing the reference
    el = body[:, None] * a[None, :]                            # positions at t = 0
    for cone_deg in (30.0, 60.0, 90.0, 120.0):
        th = np.deg2rad(cone_deg)
        u = np.array([np.sin(heading + th), np.cos(heading + th)])   # starboard
        src = 1e6 * u                                          # far: a plane wave
        # the reference receives at t = 0; T0 = its travel time
        t0 = np.linalg.norm(src - el[0]) / C
        # element n at e_n + V t receives at t: |e_n + V t − src| = c (t + T0)
        vel = v * a
        q = el - src
        qa = vel @ vel - C * C
        qb = 2 * (q @ vel - C * C * t0)
        qc = np.sum(q * q, 1) - (C * t0) ** 2
        t_n = (-qb - np.sqrt(qb * qb - 4 * qa * qc)) / (2 * qa)   # the root near 0
        static = (np.linalg.norm(src - el, axis=1) - np.linalg.norm(src - el[0])) / C
        meas = t_n
        ct = np.cos(th)
        np.testing.assert_allclose(meas[1:], static[1:] / (1 + v / C * ct), rtol=1e-6,
                                   atol=1e-12)
        corrected = static_delays(meas[None, :], np.array([v * ct]), C)[0]
        assert np.max(np.abs(corrected - static)) < 1e-3 * max(
            np.max(np.abs(meas - static)), 1e-12) + 1e-12
        # apparent cone from the measured delays (least squares on cos θ = −c τ / d)
        d = body[1:] - body[0]
        cos_app = np.dot(d, -C * meas[1:]) / np.dot(d, d)
        # (the wavefront's curvature at 1000 km changes cos θ by ~1e-5; the effect is 1e-3)
        if cone_deg != 90.0:
            assert abs(cos_app - ct) > 50 * abs(cos_app - ct / (1 + v / C * ct))
        assert cos_app == pytest.approx(ct / (1 + v / C * ct), abs=3e-5)
        stat = np.arccos(np.dot(d, -C * static[1:]) / np.dot(d, d))
        assert static_cone(np.arccos(cos_app), v, C) == pytest.approx(stat, abs=1e-7)
    # 3 m/s at 60°: the apparent cone is 0.034° wider
    assert np.rad2deg(np.arccos(0.5 / (1 + 3.0 / C * 0.5)) - np.pi / 3) == pytest.approx(
        0.0331, abs=5e-4)


def test_nav_velocity_and_axial_speed():
    class Nav:
        time = np.array([0.0, 10.0, 20.0])
        position = np.array([[0.0, 0.0], [0.0, 30.0], [40.0, 30.0]])
    v = nav_velocity(Nav, np.array([5.0, 15.0, 25.0]))
    np.testing.assert_allclose(v, [[0.0, 3.0], [4.0, 0.0], [4.0, 0.0]])
    np.testing.assert_allclose(axial_speed(v, np.deg2rad([0.0, 90.0, 270.0])), [3, 4, -4],
                               atol=1e-12)


SCENARIO = """
[recording]
fs = 2048.0
duration = 60.0
sound_speed = 1500.0
seed = 3
start_time = "2026-01-01T00:00:00Z"

[array]
type = "line"
n = 16
spacing = 1.0
depth = 30.0

[ownship]
start = [0.0, 0.0]
[[ownship.leg]]
course = 0.0
speed_kn = 20.0
duration = 60.0

[[source]]
name = "target"
start = [{x}, {y}]
depth = 30.0
course = 0.0
speed_kn = 0.0
[source.broadband]
band = [100.0, 900.0]
level_db = 140.0

[propagation]
loss = "spherical"

[noise]
level_db = 50.0
"""

CHAIN = """
[input]
block = 8192

[[stage]]
type = "tde"
nfft = 4096
hop = 4096
band = [120.0, 900.0]
"""


def test_simulated_moving_array_delays_follow_m1(tmp_path):
    """The simulator renders the array's motion exactly (retarded time per element); at
    20 kn (10.3 m/s) along the axis the `tde` delays of a static source ahead of the beam
    (cone ≈ 60°) are the static delays / (1 + (v/c) cos θ) (M1), not the static delays."""
    src = 3000.0 * np.array([np.sin(np.pi / 3), np.cos(np.pi / 3)]) + [0.0, 300.0]
    (tmp_path / "s.toml").write_text(SCENARIO.format(x=src[0], y=src[1]))
    (tmp_path / "c.toml").write_text(CHAIN)
    rec_p, prod_p = tmp_path / "rec.h5", tmp_path / "d.h5"
    simulate(str(tmp_path / "s.toml"), str(rec_p))
    process(str(rec_p), str(tmp_path / "c.toml"), str(prod_p))
    g = read_products(str(prod_p))["tde"]
    t, tau, sig = g["time"], g["tau"], g["sigma"]
    with Recording(rec_p) as rec:
        poses = rec.poses(t)
        vel = nav_velocity(rec.nav, t)
    el = np.stack([p.elements for p in poses])                          # (B, N, 3)
    s3 = np.r_[src, 30.0]
    r = np.linalg.norm(s3[None, None] - el, axis=-1)
    static = (r - r[:, :1]) / C
    hd = np.deg2rad([p.heading for p in poses])
    v_ax = axial_speed(vel, hd)
    d = s3[None, :2] - el[:, 0, :2]
    cos_t = (d[:, 0] * np.sin(hd) + d[:, 1] * np.cos(hd)) / np.hypot(d[:, 0], d[:, 1])
    assert np.all(np.abs(v_ax - 20 * 1852 / 3600) < 1e-6)
    assert np.all((cos_t > 0.3) & (cos_t < 0.6))
    moving = static / (1 + v_ax / C * cos_t)[:, None]
    w = 1.0 / sig[:, 1:] ** 2

    def chi2(model):
        return float(np.sum(w * (tau[:, 1:] - model[:, 1:]) ** 2) / w.size)

    # the delays follow (M1): chi² per delay near 1, the static model is far off
    assert chi2(moving) < 3.0, chi2(moving)
    assert chi2(static) > 10 * chi2(moving), (chi2(static), chi2(moving))
    # and (M2) brings the measured delays back to the static ones
    corrected = static_delays(tau, v_ax * cos_t, C)
    assert float(np.sum(w * (corrected[:, 1:] - static[:, 1:]) ** 2) / w.size) < 3.0
