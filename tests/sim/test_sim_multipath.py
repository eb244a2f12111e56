"""Image-source multipath of the simulator against closed forms: Lloyd's mirror (two-path
level against range, nulls included), the rough surface's coherent reflection, bottom-reflected
delay and level, and the active echo's multipath arrivals."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import csd, welch

from arrayproc.errors import ConfigError
from arrayproc.evaluate.scenarios.realism import C, ranged_scenario, tonal_phasor, two_path
from arrayproc.sim.multipath import images
from arrayproc.sim.run import Simulator
from arrayproc.sim.scenario import MultipathSpec, parse_scenario
from arrayproc.sim.sources import tonal_amplitude


def local_max_mask(level_db, r, frac=0.2, within=10.0):
    """Points whose closed-form level is within ``within`` dB of its maximum over ±frac·r."""
    mx = np.array([level_db[np.abs(r - ri) <= frac * ri].max() for ri in r])
    return level_db >= mx - within


def test_image_enumeration_counts_reflections():
    spec = MultipathSpec(surface=True, bottom_depth=100.0, bottom_loss_db=6.0, order=2)
    im = images(spec)
    zs, d = 30.0, 100.0
    got = {(x.n_surface, x.n_bottom): x.depth(zs) for x in im}
    # direct, S, B, SB, BS, SS? (impossible in a waveguide), BB? (impossible)
    assert got[(0, 0)] == zs and got[(1, 0)] == -zs and got[(0, 1)] == 2 * d - zs
    assert sorted(v for k, v in got.items() if k == (1, 1)) == [2 * d + zs]
    assert len(im) == 1 + 2 + 2  # order 2: S, B, SB, BS (distinct images zs ± 2D)
    assert sorted(x.depth(zs) for x in im if x.order == 2) == [zs - 2 * d, zs + 2 * d]
    coefs = {(x.n_surface, x.n_bottom): x.coef for x in im}
    assert coefs[(1, 0)] == -1.0 and coefs[(0, 1)] == pytest.approx(10 ** (-0.3))
    assert len(images(MultipathSpec(surface=True, bottom_depth=None, order=5))) == 2


def test_lloyds_mirror_level_against_range_nulls_included():
    """Two-path level vs range within 1 dB where the field is within 10 dB of its local max."""
    zs, zr, f, fs = 20.0, 50.0, 1000.0, 4096.0
    r = np.linspace(100.0, 3000.0, 600)
    scen = ranged_scenario(r, zs, zr, {"surface": True, "order": 1})
    sim = Simulator(scen)
    x = sim.render(0, 2048).astype(float)
    meas = 20 * np.log10(np.abs(tonal_phasor(x, f, fs)))
    cf = 20 * np.log10(tonal_amplitude(120.0) * np.abs(two_path(r, zs, zr, f, -1.0)))
    mask = local_max_mask(cf, r)
    err = np.abs(meas - cf)[mask]
    # closed-form nulls r_n = 2 zs zr f/(c n) (far-field): the simulated field has them too
    r_null = []
    for n in range(1, 6):
        rn = 2 * zs * zr * f / (C * n)
        sel = np.abs(r - rn) < 0.15 * rn
        r_null.append((rn, r[sel][np.argmin(meas[sel])], cf[sel].max() - meas[sel].min()))
    print(f"Lloyd's mirror, {mask.sum()} of {r.size} ranges within 10 dB of the local max: "
          f"max |sim - two-path| = {err.max():.3f} dB, median {np.median(err):.3f} dB")
    for rn, rs, depth in r_null:
        print(f"  null near {rn:7.1f} m (far field): simulated minimum at {rs:7.1f} m, "
              f"{depth:.1f} dB below the fringe's maximum")
    assert mask.sum() > 0.6 * r.size and (~mask).sum() > 20  # the nulls are really there
    assert err.max() < 1.0
    for rn, rs, depth in r_null:
        assert abs(rs - rn) < 0.03 * rn + 5.0 and depth > 15.0
    # and everywhere the field is not in a null, much closer than 1 dB
    assert np.median(err) < 0.05


def test_rough_surface_coherent_reflection():
    """Rayleigh parameter Γ = 2kσ sin θ: the surface path is scaled by exp(-Γ²/2)."""
    zs, zr, f, fs, sigma = 20.0, 50.0, 1000.0, 4096.0, 0.4
    r = np.linspace(100.0, 3000.0, 200)
    scen = ranged_scenario(r, zs, zr, {"surface": True, "order": 1, "surface_rms_height": sigma,
                                       "roughness_freq": f})
    x = Simulator(scen).render(0, 2048).astype(float)
    ph = tonal_phasor(x, f, fs) / tonal_amplitude(120.0)
    k = 2 * np.pi * f / C
    sin_t = (zs + zr) / np.hypot(r, zs + zr)
    refl = -np.exp(-2 * (k * sigma * sin_t) ** 2)
    cf = two_path(r, zs, zr, f, refl)
    smooth = two_path(r, zs, zr, f, -1.0)
    rel = np.abs(ph - cf) / np.abs(cf)
    print(f"rough surface σ = {sigma} m at {f:g} Hz: Γ from {2 * k * sigma * sin_t.min():.2f} "
          f"to {2 * k * sigma * sin_t.max():.2f}; max |sim - closed form|/|closed form| = "
          f"{rel.max():.2e}; smooth-surface model would be off by up to "
          f"{(np.abs(smooth - cf) / np.abs(cf)).max():.2f}")
    assert rel.max() < 0.01
    assert (np.abs(smooth - cf) / np.abs(cf)).max() > 0.3  # the roughness matters here


def test_bottom_reflected_delay_and_level():
    """Broadband source, flat bottom D with 6 dB loss and no surface: the bottom path arrives
    (R2 − R1)/c after the direct one with level 20 log10(R1/R2) − 6 dB."""
    zs, zr, d, bl, fs, rng = 30.0, 60.0, 100.0, 6.0, 4096.0, 300.0
    src = {"broadband": {"band": [100.0, 1600.0], "level_db": 100.0}}
    kw = dict(fs=fs, duration=4.0, source=src)
    mp = {"surface": False, "bottom_depth": d, "bottom_loss_db": bl, "order": 1}
    both = Simulator(ranged_scenario([rng], zs, zr, mp, **kw))
    direct = Simulator(ranged_scenario([rng], zs, zr, {"surface": False, "order": 0}, **kw))
    n = int(4.0 * fs)
    xb = both.render(0, n)[:, 0].astype(float)
    xd = direct.render(0, n)[:, 0].astype(float)
    # transfer function of the bottom path: H(f) = S_bd/S_dd − 1 = a·exp(−2πifΔτ)
    f, s_bd = csd(xd, xb, fs, nperseg=4096)
    _, s_dd = welch(xd, fs, nperseg=4096)
    band = (f > 150.0) & (f < 1500.0)
    h = (s_bd / s_dd)[band] - 1.0
    ph = np.unwrap(np.angle(h))
    meas_lag = -np.polyfit(2 * np.pi * f[band], ph, 1)[0]
    meas_db = 20 * np.log10(np.mean(np.abs(h)))
    r1 = np.hypot(rng, zs - zr)
    r2 = np.hypot(rng, 2 * d - zs - zr)
    lag = (r2 - r1) / C
    cf_db = 20 * np.log10(r1 / r2) - bl
    print(f"bottom path: delay {meas_lag * 1e3:.5f} ms (closed form {lag * 1e3:.5f} ms, "
          f"error {(meas_lag - lag) * fs:.4f} samples); level {meas_db:.3f} dB re direct "
          f"(closed form {cf_db:.3f} dB)")
    assert abs(meas_lag - lag) < 0.01 / fs
    assert abs(meas_db - cf_db) < 0.1
    # the truth records the paths at the reference point (the origin, above the source)
    s = both.truth()[0]["sources"]["s"]
    np.testing.assert_allclose(s["path_delay_s"][0], [abs(zs - zr) / C, (2 * d - zs - zr) / C],
                               rtol=1e-12)
    np.testing.assert_allclose(s["path_amplitude"][0], [1 / abs(zs - zr),
                                                        10 ** (-bl / 20) / (2 * d - zs - zr)],
                               rtol=1e-9)


def test_multipath_refuses_non_spherical_and_dry_points():
    with pytest.raises(ConfigError, match="spherical"):
        parse_scenario({
            "recording": {"fs": 1000.0, "duration": 1.0},
            "array": {"type": "line", "n": 2, "spacing": 1.0, "depth": 10.0},
            "source": [{"start": [100.0, 0.0], "depth": 5.0, "heading": 0.0,
                        "tonals": [{"freq": 100.0, "level_db": 120.0}]}],
            "propagation": {"loss": "cylindrical", "multipath": {"surface": True}}})
    with pytest.raises(ConfigError, match="outside the water"):
        parse_scenario({
            "recording": {"fs": 1000.0, "duration": 1.0},
            "array": {"type": "line", "n": 2, "spacing": 1.0, "depth": 10.0},
            "source": [{"start": [100.0, 0.0], "depth": 150.0, "heading": 0.0,
                        "tonals": [{"freq": 100.0, "level_db": 120.0}]}],
            "propagation": {"multipath": {"bottom_depth": 100.0}}})
    with pytest.raises(ConfigError, match="roughness_freq"):
        parse_scenario({
            "recording": {"fs": 1000.0, "duration": 1.0},
            "array": {"type": "line", "n": 2, "spacing": 1.0, "depth": 10.0},
            "source": [{"start": [100.0, 0.0], "depth": 5.0, "heading": 0.0,
                        "tonals": [{"freq": 100.0, "level_db": 120.0}]}],
            "propagation": {"multipath": {"surface_rms_height": 0.3}}})


def echo_scenario(multipath: dict, r0: float = 500.0, zt: float = 50.0, zr: float = 30.0):
    return parse_scenario({
        "recording": {"fs": 5120.0, "duration": 0.2 + 2 * r0 / C + 0.6, "sound_speed": C,
                      "seed": 1},
        "array": {"type": "line", "n": 1, "spacing": 1.0, "depth": zr},
        "ownship": {"start": [0.0, 0.0], "heading": 0.0},
        "propagation": {"multipath": multipath},
        "active": {"waveform": "hfm", "f0": 1000.0, "f1": 2000.0, "duration": 0.2,
                   "level_db": 200.0, "interval": 100.0, "first": 0.1, "count": 1,
                   "offset": [0.0, 0.0, 0.0], "direct": False, "taper": 0.1,
                   "target": [{"name": "t", "start": [0.0, r0], "depth": zt, "heading": 0.0,
                               "ts_db": 0.0}]},
    })


def test_echo_over_four_surface_paths():
    """Static monostatic sonar, static target, pressure-release surface: the echo is the
    direct echo filtered by H(f) = (1 − (R1/R2)e^{−iωΔ})², Δ = (R2 − R1)/c (paths DD, DS, SD,
    SS with coefficients 1, −1, −1, +1 and spreading 1/(r_a r_b))."""
    r0, zt, zr = 500.0, 50.0, 30.0
    mp = Simulator(echo_scenario({"surface": True, "order": 1}, r0, zt, zr))
    dd = Simulator(echo_scenario({"surface": True, "order": 0}, r0, zt, zr))
    assert len(mp.active.path_pairs) == 4 and len(dd.active.path_pairs) == 1
    xm = mp.render(0, mp.n_samples)[:, 0].astype(float)
    xd = dd.render(0, dd.n_samples)[:, 0].astype(float)
    n = 2 * xm.size
    f = np.fft.rfftfreq(n, 1 / 5120.0)
    band = (f > 1100.0) & (f < 1900.0)
    h = (np.fft.rfft(xm, n) / np.fft.rfft(xd, n))[band]
    r1, r2 = np.hypot(r0, zt - zr), np.hypot(r0, zt + zr)
    cf = (1 - (r1 / r2) * np.exp(-2j * np.pi * f[band] * (r2 - r1) / C)) ** 2
    err = np.abs(h - cf).max() / np.abs(cf).max()
    print(f"echo multipath: max |H_sim − H_closed| / max|H| = {err:.2e} over 1.1-1.9 kHz "
          f"(|H| from {np.abs(cf).min():.3f} to {np.abs(cf).max():.3f})")
    assert err < 0.01


def test_realistic_scenario_is_chunk_independent_and_seeded():
    """Multipath + water-pulled array + unsteady tonals (the bundled towed_realistic.toml):
    the same samples whatever the chunking (exact: the same code on the same absolute
    indices), a different seed gives a different recording."""
    from arrayproc.data import data_path
    from arrayproc.sim.scenario import load_scenario

    scen = load_scenario(data_path("scenarios", "towed_realistic.toml"))
    a = Simulator(scen)
    k0 = int(75.0 * scen.fs)  # in the turn
    whole = a.render(k0, k0 + 6000)
    b = Simulator(load_scenario(data_path("scenarios", "towed_realistic.toml")))
    parts = np.concatenate([b.render(k0, k0 + 1234), b.render(k0 + 1234, k0 + 6000)])
    assert np.array_equal(whole, parts)
    scen.seed = 2
    other = Simulator(scen).render(k0, k0 + 6000)
    assert not np.allclose(other, whole)
