"""MVDR (Capon) against closed forms: the power and white-noise gain of loaded weights for a
known covariance (Sherman-Morrison), the WNG constraint, resolution of two sources half a CBF
beamwidth apart, and the lag-path kernels against plain numpy."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq

from arrayproc.errors import ConfigError
from arrayproc.evaluate.scenarios.beamformers import closed_form, exact_cov, resolved
from arrayproc.io.geometry import line_array
from arrayproc.sim.snapshot_spectra import C, blocks, spectra, steer
from arrayproc.stages.beamform import _adaptive_kernels as ka
from arrayproc.stages.beamform._steering import Steering, form_reference
from arrayproc.stages.beamform.mvdr import MVDR

N, DX = 32, 0.75


def cone_dirs(cones):
    d = np.zeros((len(cones), 3))
    d[:, 0] = np.cos(np.deg2rad(cones))
    return d


@pytest.mark.parametrize("geometry", ["ula", "gapped", "random"])
def test_form_matches_numpy(geometry, rng):
    """a^H Q a by co-array lags (line arrays) or chunked GEMMs against einsum; rounding of
    the phasor recursion and the sums: 1e-9 relative to ‖Q‖·N is ample."""
    pos = line_array(12, DX)
    if geometry == "gapped":
        pos = pos[[0, 1, 2, 5, 6, 9, 11]]
    if geometry == "random":
        pos = rng.normal(0, 2.0, (9, 3))
    freqs = np.array([300.0, 650.0, 990.0])
    cones = np.linspace(0, 180, 37)
    mode = "3d" if geometry == "random" else "cone"
    dirs = cone_dirs(cones) if mode == "cone" else np.stack(
        [np.cos(np.deg2rad(cones)), np.sin(np.deg2rad(cones)), 0 * cones], -1)
    st = Steering(pos, dirs, mode, freqs, C)
    assert st.lag_path == (geometry != "random")
    a = rng.standard_normal((3, pos.shape[0], 5)) + 1j * rng.standard_normal((3, pos.shape[0], 5))
    q = a @ a.conj().transpose(0, 2, 1)
    got = st.form(q)
    want = form_reference(q, st.matrix(slice(None)))
    assert np.max(np.abs(got - want)) < 1e-9 * np.abs(q).max() * pos.shape[0]


def stage_on(pos, freqs, cones, **kw):
    st = MVDR(beams={"start": float(cones[0]), "stop": float(cones[-1]),
                     "count": len(cones)}, **kw)
    st.prepare(pos, freqs)
    return st


@pytest.mark.parametrize("loading", [0.0, 0.01, 0.3, 3.0])
def test_power_matches_sherman_morrison(loading):
    """Capon estimate and output power of loaded weights for an exact covariance (white noise
    plus a 20 dB interferer at 97°), against the closed form; float64 throughout: 1e-9."""
    pos = line_array(N, DX)
    f = 900.0
    r, v, s2 = exact_cov(pos, f, 97.0, 20.0)
    cones = np.linspace(60, 120, 121)
    delta = loading * np.trace(r).real / N
    for power in ("capon", "output"):
        st = stage_on(pos, np.array([f]), cones, loading=loading, power=power)
        got = st.spectrum(r[None], slice(0, 1))[0] / N**2
        want = np.array([closed_form(steer(pos, c, np.array([f]))[0], v, s2, 1.0, delta)
                         [0 if power == "capon" else 2] for c in cones])
        assert np.max(np.abs(got / want - 1)) < 1e-9


def test_wng_constraint_matches_closed_form():
    """With ``wng_db`` the loading per beam is the δ at which the closed-form WNG of the
    loaded weights equals the floor (where the unconstrained weights fall short), and the
    power is the closed-form one at that δ. Looking 1° from a 30 dB interferer, unconstrained
    MVDR has a WNG far below N; the constraint holds it at 12 dB (N = 32: at most 15.05 dB)."""
    pos = line_array(N, DX)
    f = 900.0
    r, v, s2 = exact_cov(pos, f, 90.0, 30.0)
    cones = np.array([91.0, 93.0, 100.0, 120.0])
    floor_db = 12.0
    st = stage_on(pos, np.array([f]), np.linspace(91, 120, 30), loading=0.0, wng_db=floor_db)
    st.steering = st.steering.__class__(pos, cone_dirs(cones), "cone", np.array([f]), C)
    power, delta, wng = st._wng_power(r[None], np.zeros(1), slice(0, 1))
    for j, c in enumerate(cones):
        a = steer(pos, c, np.array([f]))[0]
        w0 = closed_form(a, v, s2, 1.0, 0.0)[1]
        if 10 * np.log10(w0) >= floor_db:
            assert delta[0, j] == 0.0
            continue
        def excess(x, a=a):
            return 10 * np.log10(closed_form(a, v, s2, 1.0, x)[1]) - floor_db

        d = brentq(excess, 0.0, 1e8, xtol=1e-12, rtol=1e-12)
        assert abs(delta[0, j] / d - 1) < 1e-6, (c, delta[0, j], d)
        assert abs(10 * np.log10(wng[0, j]) - floor_db) < 1e-6
        assert abs(power[0, j] * closed_form(a, v, s2, 1.0, d)[0] ** -1 - 1) < 1e-6
    assert delta[0, 0] > 0  # the 91° beam needed loading


def test_array_gain_against_loading():
    """Array gain AG = SINR_out / SINR_in = (σ² + σ_i²) / w^H R w (distortionless signal) of
    a beam at 90° with a 20 dB interferer at 95°, against loading: the stage's output power
    equals the closed form at every loading; unloaded it is the optimum (σ² + σ_i²) a^H R⁻¹ a,
    and it falls monotonically with loading towards the CBF gain."""
    pos = line_array(N, DX)
    f = 900.0
    r, v, s2 = exact_cov(pos, f, 95.0, 20.0)
    a = steer(pos, 90.0, np.array([f]))[0]
    gains = []
    for eps in (0.0, 0.01, 0.1, 1.0, 10.0, 1e7):
        d = eps * np.trace(r).real / N
        _, wng, out = closed_form(a, v, s2, 1.0, d)
        st = stage_on(pos, np.array([f]), [90.0, 90.0], loading=eps, power="output")
        got = st.spectrum(r[None], slice(0, 1))[0, 0] / N**2
        assert abs(got / out - 1) < 1e-9
        gains.append((1.0 + s2) / out)
    cbf_out = (N + s2 * abs(np.vdot(v, a)) ** 2) / N**2
    opt = closed_form(a, v, s2, 1.0, 0.0)[2]
    assert abs(gains[0] / ((1 + s2) / opt) - 1) < 1e-9
    assert gains[0] > gains[-1]  # loading trades interference rejection ...
    assert abs(gains[-1] * cbf_out / (1 + s2) - 1) < 1e-3  # ... towards the CBF gain
    assert np.all(np.diff(gains) <= 1e-12)


def resolution_trial(rng, snr_db=10.0, groups=10, snapshots=64, **kw):
    """Two independent sources 0.5 CBF beamwidths apart at broadside (N = 32, 800-1000 Hz):
    per group the two strongest peaks of the broadband power of MVDR and of CBF."""
    pos = line_array(N, DX)
    freqs = np.arange(800.0, 1000.1, 5.0)
    bw = np.rad2deg(0.886 * C / (900.0 * N * DX))  # eq. (2.41) at the band centre
    truth = [90.0 - bw / 4, 90.0 + bw / 4]
    x = spectra(pos, freqs, truth, snr_db, groups * snapshots, rng)
    st = MVDR(beams={"start": 84.0, "stop": 96.0, "count": 241}, snapshots=snapshots,
              output="broadband", **kw)
    out = list(st.process(blocks(x, freqs, pos)))
    cbf = []
    for g in range(groups):
        xs = x[g * snapshots:(g + 1) * snapshots]
        r = np.einsum("kfc,kfd->fcd", xs, xs.conj()) / snapshots
        cbf.append(st.steering.form(r).sum(0))
    return truth, st.beam_axis, [o.data[0, 0] for o in out], cbf


def test_resolves_half_a_beamwidth_where_cbf_does_not(rng):
    truth, axis, mv, cbf = resolution_trial(rng)
    ok_mv = sum(resolved(p, axis, truth) for p in mv)
    ok_cbf = sum(resolved(p, axis, truth, tol=0.5) for p in cbf)
    assert ok_mv >= 8, ok_mv
    assert ok_cbf == 0, ok_cbf


def test_forward_backward_resolves_too(rng):
    truth, axis, mv, _ = resolution_trial(rng, groups=4, forward_backward=True)
    assert sum(resolved(p, axis, truth) for p in mv) >= 3


def test_lag_kernel_matches_loop(rng):
    q = rng.standard_normal((2, 5, 5)) + 1j * rng.standard_normal((2, 5, 5))
    lag = np.array([0, 2, 3, 1, 4])
    s = np.empty((2, 5), complex)
    ka.lag_sums(q, lag, s)
    want = np.zeros((2, 5), complex)
    for m in range(5):
        for n in range(5):
            if lag[n] >= lag[m]:
                want[:, lag[n] - lag[m]] += q[:, m, n]
    assert np.allclose(s, want, rtol=1e-14, atol=1e-14)


def test_refusals():
    pos = line_array(N, DX)
    with pytest.raises(ConfigError, match="singular"):
        stage_on(pos, np.array([900.0]), [80.0, 100.0], loading=0.0, snapshots=8)
    with pytest.raises(ConfigError, match="centro-symmetric"):
        stage_on(pos[[0, 1, 3, 4, 9]], np.array([900.0]), [80.0, 100.0],
                 forward_backward=True)
    with pytest.raises(ConfigError, match="white-noise gain"):
        stage_on(pos, np.array([900.0]), [80.0, 100.0], wng_db=16.0)
    with pytest.raises(ConfigError, match="loading"):
        MVDR(loading=-1.0)


@pytest.mark.parametrize("kind", ["mvdr", "music"])
def test_block_cuts_do_not_change_the_output(kind, rng):
    """The same time series cut into blocks of 8192 or of 1500 samples, and started half way
    (on the group grid): identical bytes for the groups both runs form (groups are aligned on
    the absolute snapshot grid and multiplied out whole)."""
    from arrayproc.chain.memory import array_blocks
    from arrayproc.stages.beamform.music import MUSIC
    pos = line_array(16, DX)
    fs = 5120.0
    x = rng.standard_normal((40000, 16)).astype(np.float32)

    def run(sizes, start=0):
        kw = dict(nfft=512, hop=256, band=[300.0, 900.0], snapshots=16,
                  beams={"start": 60.0, "stop": 120.0, "count": 31})
        st = MVDR(**kw) if kind == "mvdr" else MUSIC(sources=2, **kw)
        out = list(st.process(array_blocks(x[start:], fs, pos, sizes, start=start)))
        return {round(float(o.meta.times[0]), 9): o.data.tobytes() for o in out}

    whole = run((8192,))
    cut = run((1500,))
    late = run((3000,), start=16 * 256 * 3)
    assert whole == cut
    assert late and all(whole[t] == v for t, v in late.items())


def test_power_on_a_volumetric_array_matches_sherman_morrison(rng):
    """Any geometry (the general GEMM path): 12 elements at random 3-D positions, 3-D beams
    (bearings × elevations), a 20 dB interferer; Capon power against Sherman-Morrison, 1e-9."""
    pos = rng.normal(0, 1.5, (12, 3))
    f = 400.0
    brg = np.linspace(-180, 170, 36)
    st = MVDR(beams={"bearings": brg.tolist(), "elevations": [-20.0, 0.0, 30.0]}, loading=0.05)
    st.prepare(pos, np.array([f]))
    assert not st.steering.lag_path
    a = st.steering.matrix(slice(0, 1))[0]  # (C, B)
    v = a[:, 7]  # interferer from beam 7's direction
    s2 = 100.0
    r = np.eye(12) + s2 * np.outer(v, v.conj())
    delta = 0.05 * np.trace(r).real / 12
    got = st.spectrum(r[None], slice(0, 1))[0] / 12**2
    want = np.array([closed_form(a[:, b], v, s2, 1.0, delta)[0] for b in range(a.shape[1])])
    assert np.max(np.abs(got / want - 1)) < 1e-9
