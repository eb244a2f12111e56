"""Simulator physics against closed forms: phases, Doppler, levels, delays.

Each test prints its measured error (run with ``-s`` to see the numbers quoted in
docs/validation.md).
"""

from __future__ import annotations

import copy

import numpy as np
from scipy.signal import welch

from arrayproc.data import data_path
from arrayproc.sim.run import Simulator
from arrayproc.sim.scenario import parse_scenario

C = 1500.0


def scenario(**over) -> dict:
    base = {
        "recording": {"fs": 2048.0, "duration": 4.0, "sound_speed": C, "seed": 3},
        "array": {"type": "line", "n": 8, "spacing": 0.75, "depth": 50.0},
        "ownship": {"start": [0.0, 0.0], "heading": 0.0},
    }
    d = copy.deepcopy(base)
    for k, v in over.items():
        if isinstance(v, dict) and k in d:
            d[k].update(v)
        else:
            d[k] = v
    return d


def render(d: dict, t0: float = 0.0, t1: float | None = None) -> tuple[Simulator, np.ndarray]:
    sim = Simulator(parse_scenario(d, "test.toml"))
    k0 = int(round(t0 * sim.fs))
    k1 = sim.n_samples if t1 is None else int(round(t1 * sim.fs))
    return sim, sim.render(k0, k1).astype(float)


def peak_frequency(x: np.ndarray, fs: float, f_guess: float, pad: int = 1 << 21) -> float:
    """Peak of a Hann-windowed, zero-padded FFT refined by a parabola on log magnitude."""
    w = np.hanning(x.size)
    spec = np.abs(np.fft.rfft(x * w, pad))
    df = fs / pad
    lo, hi = int((f_guess - 2) / df), int((f_guess + 2) / df)
    i = lo + int(np.argmax(spec[lo:hi]))
    a, b, c = np.log(spec[i - 1: i + 2])
    return (i + 0.5 * (a - c) / (a - 2 * b + c)) * df


def test_far_tonal_phases_match_geometry():
    f = 500.0  # Hz: 1000 cycles in 2 s
    src = {"name": "far", "start": [2000 * np.sin(np.deg2rad(60)), 2000 * np.cos(np.deg2rad(60))],
           "depth": 50.0, "heading": 0.0, "tonals": [{"freq": f, "level_db": 150.0}]}
    sim, x = render(scenario(source=[src], recording={"duration": 3.0}), 1.0, 3.0)
    k = np.arange(x.shape[0])
    z = (x * np.exp(-2j * np.pi * f * k / sim.fs)[:, None]).sum(0)
    phase = np.angle(z * np.exp(2j * np.pi * f * 1.0))  # reference to t = 0 of the window
    pos = sim.element_positions(0.0)
    r = np.linalg.norm(pos - np.array([*src["start"], 50.0]), axis=1)
    want = -2 * np.pi * f * (r - r[0]) / C
    err = np.angle(np.exp(1j * ((phase - phase[0]) - want)))
    print(f"tonal inter-element phase: max error {np.max(np.abs(err)):.2e} rad (tol 0.01)")
    assert np.max(np.abs(err)) < 0.01


def test_doppler_of_receding_source_one_way():
    f, rdot, T = 300.0, 5.0, 20.0
    src = {"name": "s", "start": [0.0, 1000.0], "depth": 50.0, "course": 0.0, "speed": rdot,
           "tonals": [{"freq": f, "level_db": 150.0}]}
    sim, x = render(scenario(source=[src], array={"n": 1}, recording={"duration": T + 1}),
                    1.0, T + 1)
    fm = peak_frequency(x[:, 0], sim.fs, f * (1 - rdot / C))
    first_order = f * (1 - rdot / C)
    exact = f / (1 + rdot / C)  # moving source, stationary receiver
    print(f"one-way Doppler: measured {fm:.5f} Hz, f(1-rdot/c) {first_order:.5f} Hz "
          f"(err {fm - first_order:+.5f}), exact f/(1+rdot/c) {exact:.5f} Hz "
          f"(err {fm - exact:+.5f}); tol 0.01 Hz")
    assert abs(fm - first_order) < 0.01
    assert abs(fm - exact) < 0.01


def test_doppler_fast_source_follows_exact_law():
    f, rdot = 800.0, -12.0  # closing at 12 m/s: f/(1+rdot/c) differs from f(1-rdot/c) by 0.05 Hz
    src = {"name": "s", "start": [0.0, 3000.0], "depth": 50.0, "course": 180.0,
           "speed": -rdot, "tonals": [{"freq": f, "level_db": 150.0}]}
    sim, x = render(scenario(source=[src], array={"n": 1}, recording={"duration": 21.0}),
                    1.0, 21.0)
    fm = peak_frequency(x[:, 0], sim.fs, f * (1 - rdot / C))
    exact = f / (1 + rdot / C)
    print(f"one-way Doppler (closing 12 m/s): measured {fm:.5f} Hz vs exact {exact:.5f} "
          f"(err {fm - exact:+.5f}; first-order law off by {exact - f * (1 - rdot / C):+.4f})")
    assert abs(fm - exact) < 0.01


def test_doppler_moving_receiver():
    f, u = 400.0, 6.0
    src = {"name": "s", "start": [0.0, -800.0], "depth": 50.0, "heading": 0.0,
           "tonals": [{"freq": f, "level_db": 150.0}]}
    own = {"start": [0.0, 0.0], "course": 0.0, "speed": u}  # receding from the source
    d = scenario(source=[src], array={"n": 1}, recording={"duration": 21.0})
    d["ownship"] = own
    sim, x = render(d, 1.0, 21.0)
    fm = peak_frequency(x[:, 0], sim.fs, f * (1 - u / C))
    want = f * (1 - u / C)
    print(f"moving-receiver Doppler: measured {fm:.5f} Hz vs f(1-u/c) {want:.5f} "
          f"(err {fm - want:+.5f}); tol 0.01 Hz")
    assert abs(fm - want) < 0.01


def test_tonal_level_spherical_spreading():
    f, sl, r = 250.0, 140.0, 1000.0
    src = {"name": "s", "start": [r, 0.0], "depth": 50.0, "heading": 0.0,
           "tonals": [{"freq": f, "level_db": sl}]}
    sim, x = render(scenario(source=[src], recording={"duration": 3.0}), 1.0, 3.0)
    lvl = 20 * np.log10(np.sqrt(np.mean(x**2, axis=0)) / 1e-6)
    pos = sim.element_positions(0.0)
    want = sl - 20 * np.log10(np.linalg.norm(pos - np.array([r, 0.0, 50.0]), axis=1))
    err = np.max(np.abs(lvl - want))
    print(f"tonal level: max error {err:.4f} dB (tol 0.2)")
    assert err < 0.2


def test_noise_spectral_level_flat_and_coloured():
    d = scenario(noise={"level_db": 60.0}, recording={"duration": 16.0})
    sim, x = render(d)
    f, p = welch(x, sim.fs, nperseg=1024, axis=0)
    band = (f > 20) & (f < 0.45 * sim.fs)
    lvl = 10 * np.log10(np.mean(p[band]) / 1e-12)
    print(f"flat noise: {lvl:.3f} dB re 1 uPa^2/Hz vs 60 (tol 0.3)")
    assert abs(lvl - 60.0) < 0.3
    # coloured: 70 dB at 50 Hz falling to 55 dB at 800 Hz (log-frequency interpolation)
    spec = [[50.0, 70.0], [800.0, 55.0]]
    sim, x = render(scenario(noise={"spectrum": spec}, recording={"duration": 64.0}))
    f, p = welch(x, sim.fs, nperseg=1024, axis=0)
    pm = p.mean(axis=1)
    for fq in (100.0, 200.0, 400.0):
        sel = np.abs(f - fq) < 0.1 * fq
        want = 10 * np.log10(np.mean(noise_psd_db(f[sel], spec)))
        got = 10 * np.log10(np.mean(pm[sel]) / 1e-12)
        print(f"coloured noise at {fq:.0f} Hz: {got:.3f} dB vs {want:.3f} (tol 0.3)")
        assert abs(got - want) < 0.3


def test_broadband_level_and_speed_model():
    r = 200.0
    src = {"name": "s", "start": [r, 0.0], "depth": 50.0, "heading": 0.0,
           "broadband": {"band": [200.0, 800.0], "level_db": 110.0}}
    sim, x = render(scenario(source=[src], array={"n": 2}, recording={"duration": 21.0}),
                    1.0, 21.0)
    f, p = welch(x[:, 0], sim.fs, nperseg=1024)
    sel = (f > 250) & (f < 750)
    got = 10 * np.log10(np.mean(p[sel]) / 1e-12)
    rr = np.linalg.norm(sim.element_positions(0.0)[0] - [r, 0, 50])
    want = 110.0 - 20 * np.log10(rr)
    print(f"broadband spectral level: {got:.3f} vs {want:.3f} dB (tol 0.5)")
    assert abs(got - want) < 0.5
    # SPL paper eq. (12): total level over the band from the source's speed
    v = 7.3
    src2 = {"name": "ship", "start": [r, -10.0 * v], "depth": 50.0, "course": 0.0, "speed": v,
            "broadband": {"band": [100.0, 900.0], "model": "speed"}}
    sim, x = render(scenario(source=[src2], array={"n": 1}, recording={"duration": 21.0}),
                    6.0, 14.0)  # around CPA, range ≈ r
    f, p = welch(x[:, 0], sim.fs, nperseg=512)
    sel = (f >= 100) & (f <= 900)
    total = 10 * np.log10(np.sum(p[sel]) * (f[1] - f[0]) / 1e-12)
    t_mid = np.arange(6.0, 14.0, 1 / sim.fs)
    tl = 10 * np.log10(np.mean(1.0 / np.sum(
        (sim.sources[0][0].state3(t_mid)[0] - [0, 0, 50]) ** 2, axis=1)))
    want = 170 + 53 * np.log10(v / 5.14) + tl
    print(f"speed-model band level: {total:.3f} vs {want:.3f} dB (tol 0.5)")
    assert abs(total - want) < 0.5


def noise_psd_db(f: np.ndarray, spec: list) -> np.ndarray:
    """Requested PSD (µPa²/Hz, linear) of a coloured noise spectrum, log-f interpolation."""
    s = np.asarray(spec)
    return 10 ** (np.interp(np.log(f), np.log(s[:, 0]), s[:, 1]) / 10)


def gcc_delay(a: np.ndarray, b: np.ndarray, fs: float, up: int = 64) -> float:
    """Delay of b relative to a (s): averaged cross-spectrum, zero-padded inverse FFT
    (band-limited interpolation of the cross-correlation), parabola at the peak."""
    n = 1024
    segs = a.size // n
    A = np.fft.rfft(a[: segs * n].reshape(segs, n) * np.hanning(n), axis=1)
    B = np.fft.rfft(b[: segs * n].reshape(segs, n) * np.hanning(n), axis=1)
    cs = np.mean(np.conj(A) * B, axis=0)
    cc = np.fft.irfft(cs, n * up)
    cc = np.concatenate([cc[-n * up // 2:], cc[: n * up // 2]])
    i = int(np.argmax(cc))
    y0, y1, y2 = cc[i - 1: i + 2]
    frac = 0.5 * (y0 - y2) / (y0 - 2 * y1 + y2)
    return ((i - n * up // 2) + frac) / (fs * up)


def test_broadband_delays_match_geometry():
    xs = np.array([300 * np.sin(np.deg2rad(40)), 300 * np.cos(np.deg2rad(40)), 20.0])
    src = {"name": "s", "start": xs[:2].tolist(), "depth": xs[2], "heading": 0.0,
           "broadband": {"band": [300.0, 2000.0], "level_db": 120.0}}
    d = scenario(source=[src], recording={"fs": 5120.0, "duration": 6.0})
    d["array"] = {"type": "tetrahedron", "side": 1.84, "depth": 30.0}
    sim, x = render(d, 1.0, 6.0)
    pos = sim.element_positions(0.0)
    r = np.linalg.norm(pos - xs, axis=1)
    errs = []
    for n in range(1, pos.shape[0]):
        tau = gcc_delay(x[:, 0], x[:, n], sim.fs)
        errs.append(tau - (r[n] - r[0]) / C)
    err = np.max(np.abs(errs))
    print(f"broadband inter-element delays: max error {err * 1e6:.3f} us (tol 1 us)")
    assert err < 1e-6


def _tonal_level(d: dict, r: float) -> tuple[Simulator, float]:
    sim, x = render(d, 1.0, 3.0)
    return sim, 20 * np.log10(np.sqrt(np.mean(x[:, 0] ** 2)) / 1e-6)


def test_transmission_loss_laws():
    from arrayproc.acoustics.tl.table import TLTable
    r, sl = 2000.0, 150.0
    src = {"name": "s", "start": [0.0, r], "depth": 50.0, "heading": 0.0,
           "tonals": [{"freq": 200.0, "level_db": sl}]}
    base = scenario(source=[src], array={"n": 1}, recording={"duration": 3.0})
    cases = []
    d = copy.deepcopy(base)
    d["propagation"] = {"loss": "cylindrical", "transition_range": 100.0}
    cases.append(("cylindrical", d, 20 * np.log10(100.0) + 10 * np.log10(r / 100.0)))
    d = copy.deepcopy(base)
    d["propagation"] = {"loss": "table", "range_m": [0.0, 1000.0, 3000.0],
                        "tl_db": [0.0, 60.0, 75.0]}
    cases.append(("inline table", d, 67.5))
    d = copy.deepcopy(base)
    tl_file = data_path("tl", "munk_bellhopcxx_incoherent.h5")
    d["propagation"] = {"loss": "table", "file": str(tl_file)}
    d["source"][0]["depth"] = 5.0
    d["array"]["depth"] = 300.0
    want = float(TLTable.load(tl_file)(np.hypot(r, 295.0), 5.0, 300.0))
    cases.append(("bellhop table", d, want))
    for name, d, tl in cases:
        _, lvl = _tonal_level(d, r)
        print(f"TL {name}: level {lvl:.3f} dB vs SL - TL {sl - tl:.3f} dB (tol 0.2)")
        assert abs(lvl - (sl - tl)) < 0.2


def test_towship_ahead_arrives_from_forward_endfire():
    f, dist = 72.0, 300.0
    d = scenario(array={"n": 8, "spacing": 2.0, "depth": 4.0}, recording={"duration": 4.0})
    d["ownship"] = {"start": [0.0, 0.0], "course": 90.0, "speed_kn": 5.0}
    d["noise"] = {"towship": {"distance": dist, "depth": 4.0,
                              "tonals": [{"freq": f, "level_db": 150.0}]}}
    sim, x = render(d, 1.0, 4.0)
    g, _ = sim.truth()
    own, ship = g["ownship"], g["sources"]["towship"]
    np.testing.assert_allclose(ship["position"] - own["position"], [[dist, 0.0]] * len(own["time"]),
                               atol=1e-6)
    k = np.arange(x.shape[0])
    ph = np.angle((x * np.exp(-2j * np.pi * f * k / sim.fs)[:, None]).sum(0))
    # forward end-fire (cone 0°): element n lags element 0 by n·spacing/c
    want = -2 * np.pi * f * 2.0 * np.arange(8) / C
    err = np.angle(np.exp(1j * ((ph - ph[0]) - want)))
    print(f"tow ship from forward end-fire: phase error {np.max(np.abs(err)):.3f} rad")
    assert np.max(np.abs(err)) < 0.05  # near field: 300 m vs a 14 m aperture


def test_towship_of_a_static_array_lies_along_its_heading():
    d = scenario(array={"n": 2}, recording={"duration": 1.0})
    d["ownship"] = {"start": [10.0, 20.0], "heading": 30.0}
    d["noise"] = {"towship": {"distance": -200.0, "depth": 5.0,  # behind: aft end-fire
                              "tonals": [{"freq": 50.0, "level_db": 140.0}]}}
    sim, x = render(d)
    ship = sim.truth()[0]["sources"]["towship"]["position"][0]
    h = np.deg2rad(30.0)
    want = np.array([10.0, 20.0]) - 200.0 * np.array([np.sin(h), np.cos(h)])
    np.testing.assert_allclose(ship, want, atol=1e-9)
    assert np.all(np.isfinite(x)) and np.std(x) > 0
