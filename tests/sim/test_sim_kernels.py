"""Propagation kernels against an independent numpy reference (exact retarded times from the
closed-form trajectories, analytic source signals), lateral motion perturbation, linearity."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from arrayproc.dsp.fracdelay import default_table
from arrayproc.io.geometry import body_to_world
from arrayproc.sim._propagate_kernels import oneway_accumulate
from arrayproc.sim.run import Simulator
from arrayproc.sim.scenario import parse_scenario

C = 1500.0


def manoeuvring() -> dict:
    """Turning ownship, turning source close by, lateral perturbation and position errors."""
    return {
        "recording": {"fs": 2048.0, "duration": 30.0, "sound_speed": C, "seed": 5},
        "array": {"type": "line", "n": 6, "spacing": 2.0, "depth": 40.0,
                  "position_error_std": 0.05, "lateral_std": 0.3, "lateral_snapshot": 0.5},
        "ownship": {"start": [0.0, 0.0], "leg": [
            {"course": 30.0, "speed": 3.0, "duration": 10.0},
            {"course": 120.0, "speed": 3.0, "duration": 40.0, "turn_rate": 3.0}]},
        "source": [{"name": "s", "start": [150.0, 260.0], "depth": 10.0, "leg": [
            {"course": 200.0, "speed": 8.0, "duration": 12.0},
            {"course": 280.0, "speed": 8.0, "duration": 30.0, "turn_rate": 4.0}],
            "tonals": [{"freq": 310.0, "level_db": 150.0}, {"freq": 777.0, "level_db": 140.0}]}],
    }


def exact_retarded(e: np.ndarray, t: float, mover) -> float:
    """c·τ = |e − x_S(t − τ)| by plain fixed-point iteration on the exact trajectory."""
    tau = 0.0
    for _ in range(15):  # error × (|v|/c < 0.01) per step: < 1e-20 s after 15
        tau = np.linalg.norm(e - mover.state3(np.array([t - tau]))[0][0]) / C
    return tau


def test_oneway_kernel_matches_numpy_reference():
    sim = Simulator(parse_scenario(manoeuvring(), "m.toml"))
    mover, sig, _ = sim.sources[0]
    rng = np.random.default_rng(0)
    ks = np.sort(rng.choice(np.arange(2048, sim.n_samples), 40, replace=False))
    worst_rel, worst_tau = 0.0, 0.0
    for k in ks:
        got = sim.render(int(k), int(k) + 1)[0].astype(float)
        t = k / sim.fs
        p, _, crs = sim.own.traj.state(np.array([t]))
        lat = sim.lateral_offsets[int(t / 0.5)]
        body = sim.body + np.array([0.0, lat, 0.0])
        elem = body_to_world(body, p[0], float(crs[0]), sim.own.depth)
        want = np.zeros(sim.n_channels)
        amp = np.zeros(sim.n_channels)
        for n in range(sim.n_channels):
            tau = exact_retarded(elem[n], t, mover)
            te = t - tau
            for f, a, ph in zip(sig.freqs, sig.amps, sig.phases):
                want[n] += a * np.cos(2 * np.pi * f * te + ph) / (C * tau)
                amp[n] += a / (C * tau)
        worst_rel = max(worst_rel, float(np.max(np.abs(got - want) / amp)))
    err_db = 20 * np.log10(worst_rel)
    print(f"one-way kernel vs exact numpy reference (manoeuvring): peak error {err_db:.1f} dB "
          "re the received amplitude")
    assert err_db < -60.0
    del worst_tau


def test_echo_kernel_matches_numpy_reference():
    r0 = 900.0
    d = {
        "recording": {"fs": 5120.0, "duration": 3.2, "sound_speed": C, "seed": 2},
        "array": {"type": "line", "n": 4, "spacing": 1.5, "depth": 60.0},
        "ownship": {"start": [0.0, 0.0], "leg": [
            {"course": 45.0, "speed": 2.5, "duration": 1.0},
            {"course": 90.0, "speed": 2.5, "duration": 10.0, "turn_rate": 5.0}]},
        "active": {"waveform": "hfm", "f0": 1200.0, "f1": 1800.0, "duration": 0.5,
                   "level_db": 200.0, "interval": 100.0, "first": 0.2, "count": 1,
                   "offset": [30.0, 0.0, -20.0], "direct": False, "taper": 0.1,
                   "target": [{"name": "t", "start": [r0 * 0.6, r0 * 0.8], "depth": 80.0,
                               "leg": [{"course": 10.0, "speed": 6.0, "duration": 1.5},
                                       {"course": 300.0, "speed": 6.0, "duration": 12.0,
                                        "turn_rate": 6.0}],
                               "ts_db": 5.0}]},
    }
    sim = Simulator(parse_scenario(d, "e.toml"))
    act = sim.active
    sc = act.scatterers[0]
    t_arr = act.windows["time"][0]
    ks = (np.linspace(t_arr + 0.02, t_arr + 0.48, 25) * sim.fs).astype(int)
    worst = 0.0
    for k in ks:
        got = sim.render(int(k), int(k) + 1)[0].astype(float)
        t = k / sim.fs
        p, _, crs = sim.own.traj.state(np.array([t]))
        elem = body_to_world(sim.body, p[0], float(crs[0]), sim.own.depth)
        for n in range(sim.n_channels):
            tau2 = exact_retarded(elem[n], t, sc.mover)
            ts = t - tau2
            xt = sc.mover.state3(np.array([ts]))[0][0]
            tau1 = exact_retarded(xt, ts, act.projector)
            te = ts - tau1
            a = act.amp * 10 ** (sc.ts_db / 20) / (C * tau1 * C * tau2)
            want = a * act.spec.waveform(np.array([te - act.ping_times[0]]))[0]
            worst = max(worst, abs(got[n] - want) / a)
    err_db = 20 * np.log10(worst)
    print(f"echo kernel vs exact numpy reference (moving projector and target): "
          f"peak error {err_db:.1f} dB re the echo amplitude")
    assert err_db < -60.0


def test_lateral_perturbation_phase_per_snapshot():
    """Thesis 2.2.2: a lateral offset δ constant within each snapshot, equal for every element,
    shifts a broadside tonal's phase by 2π f δ / c (exact geometry)."""
    f, snap = 250.0, 0.5
    d = {"recording": {"fs": 2048.0, "duration": 6.0, "sound_speed": C, "seed": 9},
         "array": {"type": "line", "n": 4, "spacing": 3.0, "depth": 20.0,
                   "lateral_std": 0.4, "lateral_snapshot": snap},
         "ownship": {"start": [0.0, 0.0], "heading": 0.0},
         "source": [{"name": "b", "start": [5000.0, 0.0], "depth": 20.0, "heading": 0.0,
                     "tonals": [{"freq": f, "level_db": 170.0, "phase_deg": 0.0}]}]}
    sim = Simulator(parse_scenario(d, "lat.toml"))
    x = sim.render(0, sim.n_samples).astype(float)
    n = int(snap * sim.fs)
    xs = np.array([5000.0, 0.0, 20.0])
    errs = []
    for j in range(1, 11):
        seg = x[j * n:(j + 1) * n]
        k = j * n + np.arange(n)
        ph = np.angle((seg * np.exp(-2j * np.pi * f * k / sim.fs)[:, None]).sum(0))
        pos = sim.element_positions(j * snap + 0.1)
        r = np.linalg.norm(pos - xs, axis=1)
        want = -2 * np.pi * f * r / C  # cos(2πf(t − r/c)) → phase −2πf r/c
        errs.append(np.angle(np.exp(1j * (ph - want))))
    errs = np.array(errs)
    err = np.max(np.abs(errs - np.mean(errs)))  # common source phase removed
    spread = np.ptp(sim.lateral_offsets[1:11]) * 2 * np.pi * f / C
    print(f"lateral perturbation: phase per snapshot matches geometry to {err:.2e} rad "
          f"(tol 0.01; the offsets span {spread:.2f} rad)")
    assert err < 0.01
    assert spread > 0.3  # the perturbation is really there


@settings(max_examples=10, deadline=None)
@given(a=st.floats(-5, 5), b=st.floats(-5, 5), seed=st.integers(0, 1000))
def test_propagation_is_linear_in_the_source_signal(a, b, seed):
    rng = np.random.default_rng(seed)
    n, nch = 64, 3
    t = 10.0 + np.arange(n) / 1000.0
    tau = 0.5 + 1e-4 * np.arange(n)
    sp = np.tile([0.0, 750.0, 10.0], (n, 1))
    z = np.zeros((n, 3))
    rpos = np.zeros((n, 2))
    body = rng.normal(0, 1.0, (nch, 3))
    s1, s2 = rng.standard_normal((2, 40000))

    def run(sig):
        out = np.zeros((n, nch), np.float32)
        oneway_accumulate(out, tau, sp, z, z, t, rpos, np.full(n, 10.0), np.zeros(n),
                          np.ones(n), np.zeros(n), body, C, sig, 0.0, 2000.0, default_table(),
                          0, 1.0, np.zeros(2), 0.0, 1.0, 1.0, np.ones(n),
                          np.zeros((0, nch, 3)), 0.0)
        return out.astype(float)

    lhs = run(a * s1 + b * s2)
    rhs = a * run(s1) + b * run(s2)
    np.testing.assert_allclose(lhs, rhs, atol=1e-6 * (1 + abs(a) + abs(b)) * 0.02)


def test_trajectory_kernel_matches_kinematics():
    """Numba closed-form evaluation vs arrayproc.geo.kinematics.Trajectory.state (numpy)."""
    from arrayproc.geo.kinematics import Trajectory
    from arrayproc.sim.motion import TrackMover
    traj = Trajectory.from_legs([100.0, -50.0], [
        {"course": 140.0, "speed": 2.57, "duration": 780.0},
        {"course": 20.0, "speed": 2.57, "duration": 1020.0, "turn_rate": 0.5},
        {"course": 300.0, "speed": 4.0, "duration": 100.0},
        {"course": 330.0, "speed": 1.0, "duration": 200.0, "turn_rate": 2.0, "turn": "port"}])
    t = np.concatenate([np.linspace(-50, 2300, 5001), [0.0, 780.0, 1020.0, 1800.0, 1900.0]])
    m = TrackMover(traj, 7.0)
    pos, vel, acc, crs, _ = m.evaluate(t)
    p_ref, v_ref, c_ref = traj.state(t)
    np.testing.assert_allclose(pos[:, :2], p_ref, atol=1e-6)
    np.testing.assert_allclose(vel[:, :2], v_ref, atol=1e-9)
    assert np.max(np.abs((crs - c_ref + 180) % 360 - 180)) < 1e-9
    assert np.all(pos[:, 2] == 7.0)
    # acceleration = d(velocity)/dt (central differences away from segment boundaries)
    h = 1e-3
    tt = np.array([100.0, 900.0, 1500.0, 1950.0, 2050.0])
    dv = (m.state3(tt + h)[1] - m.state3(tt - h)[1]) / (2 * h)
    np.testing.assert_allclose(m.state3(tt)[2], dv, atol=1e-6)
