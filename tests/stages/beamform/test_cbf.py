"""CBF (thesis eq. 2.8) against the thesis closed forms and an independent numpy reference."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from arrayproc.chain import build_chain
from arrayproc.chain.block import Block
from arrayproc.chain.domains import Domain, TimeMeta
from arrayproc.chain.memory import array_blocks
from arrayproc.dsp.windows import time_taper as time_window
from arrayproc.errors import ConfigError
from arrayproc.evaluate.scenarios.thesis_passive import array_gain_db, cbf_pattern, run_cbf
from arrayproc.io.geometry import line_array
from arrayproc.sim.plane_wave import tonal_plane_wave
from arrayproc.stages.beamform import _kernels as kb
from arrayproc.stages.beamform.cbf import CBF, beam_power_reference
from arrayproc.stages.passive import _kernels as kp

C = 1500.0


# -- the beam pattern, eq. (2.13) -------------------------------------------------------------
@pytest.mark.parametrize("theta0", [90.0, 60.0, 125.0])
def test_beam_pattern_matches_eq_2_13(theta0):
    """Main lobe and first sidelobes (thesis_passive.cbf_pattern: 32 hydrophones 0.75 m apart,
    f0 = 1000 Hz on a bin) against |I_NH|²."""
    f0, n_h = 1000.0, 32
    stage, got, want = cbf_pattern(theta0)
    assert stage.freqs.size == 1 and abs(stage.freqs[0] - f0) < 1e-9
    keep = want > want.max() * 10 ** (-40 / 10)  # away from the exact nulls
    err_db = 10 * np.log10(got[keep] / want[keep])
    assert np.max(np.abs(err_db)) < 0.1, np.max(np.abs(err_db))
    # the peak is N_H² (eq. 2.14)
    assert abs(10 * np.log10(got.max() / n_h**2)) < 0.1


@pytest.mark.parametrize("theta0", [90.0, 60.0])
def test_3db_beamwidth_matches_eq_2_41(theta0):
    fs, nfft, n_h, dx = 5120.0, 1024, 64, 0.36
    f0 = 200 * fs / nfft  # 1000 Hz
    pos = line_array(n_h, dx)
    x = tonal_plane_wave(nfft, fs, pos, theta0, f0, c=C)
    stage, y, _ = run_cbf(x, fs, pos, nfft=nfft, hop=nfft, window="none",
                          band=[f0 - 1, f0 + 1],
                          beams={"start": theta0 - 4, "stop": theta0 + 4, "count": 1601})
    p = np.abs(y[0, 0]) ** 2
    p_db = 10 * np.log10(p / p.max())
    th = stage.beam_axis
    k = int(np.argmax(p_db))
    above = p_db >= -3.0103
    a = k
    while above[a - 1]:
        a -= 1
    b = k
    while above[b + 1]:
        b += 1
    # linear interpolation of the two −3 dB crossings
    left = np.interp(-3.0103, [p_db[a - 1], p_db[a]], [th[a - 1], th[a]])
    right = np.interp(-3.0103, [p_db[b + 1], p_db[b]], [th[b + 1], th[b]])
    width = np.deg2rad(right - left)
    want = 0.886 * C / (f0 * n_h * dx * np.sin(np.deg2rad(theta0)))  # eq. (2.41)
    assert abs(width / want - 1) < 0.03, (width, want)


def test_array_gain_is_n_h(rng):
    """White noise vs plane wave: SNR gain at the steered beam = 10 log10 N_H (thesis 2.1.1;
    the set-up of ``thesis_passive.array_gain_db``)."""
    fs, nfft, n_h, dx = 2048.0, 512, 32, 0.75
    pos = line_array(n_h, dx)
    f0 = 150 * fs / nfft
    gain_db = array_gain_db(rng)
    assert abs(gain_db - 10 * np.log10(n_h)) < 0.3, gain_db
    noise = rng.standard_normal((nfft * 200, n_h))
    kw = dict(nfft=nfft, hop=nfft, band=[f0 - 40, f0 + 40],
              beams={"start": 70.0, "stop": 70.0, "count": 1})
    # and the noise output variance is N_DFT N_H σ² (thesis 2.1.1.1) for a rectangular window
    _, yr, _ = run_cbf(noise, fs, pos, window="none", **kw)
    assert abs(np.mean(np.abs(yr) ** 2) / (nfft * n_h) - 1) < 0.03


# -- against a plain numpy reference -----------------------------------------------------------
def test_matches_numpy_reference_across_blocks(rng):
    fs, n_h = 5120.0, 24
    pos = line_array(n_h, 0.36)
    pos[:, 0] += 0.013 * rng.standard_normal(n_h)  # a non-uniform line
    x = rng.standard_normal((9000, n_h))
    stage, y, out = run_cbf(x, fs, pos, sizes=(1000, 3333, 250), nfft=512, hop=384,
                            window="hann", band=[300.0, 1800.0], batch=5)
    n_frames = (9000 - 512) // 384 + 1  # 23
    assert [o.data.shape[0] for o in out] == [5, 5, 5, 5, n_frames - 20]
    starts = np.concatenate([o.meta.starts for o in out])
    assert np.array_equal(starts, 384 * np.arange(y.shape[0]))
    w = time_window("hann", 512)
    for s in (0, 7, y.shape[0] - 1):
        f, ref = beam_power_reference(x[starts[s]:starts[s] + 512], fs, pos, stage.beam_axis,
                                      (300.0, 1800.0), C, w)
        assert np.allclose(f, stage.freqs)
        assert np.max(np.abs(y[s] - ref)) < 2e-5 * np.max(np.abs(ref))
    times = np.concatenate([o.meta.times for o in out])
    assert np.allclose(times, (starts + 256) / fs)


def test_3d_beams_and_shading_against_einsum(rng):
    fs = 4000.0
    pos = rng.uniform(-1, 1, (12, 3))
    x = rng.standard_normal((2048, 12))
    beams = {"bearings": [0.0, 45.0, 180.0, 225.0, 300.0], "elevations": [-20.0, 0.0, 20.0]}
    stage, y, _ = run_cbf(x, fs, pos, nfft=256, hop=256, window="hamming", band=[500, 1500],
                          beams=beams, shading="hann")
    assert stage.beam_axis.shape == (15, 2)
    b, e = np.deg2rad(stage.beam_axis[:, 0]), np.deg2rad(stage.beam_axis[:, 1])
    k = np.stack([np.cos(e) * np.cos(b), np.cos(e) * np.sin(b), -np.sin(e)], -1)
    tau = k @ (pos - pos.mean(0)).T / C  # (B, C)
    w = time_window("hamming", 256)
    spec = np.fft.rfft(x[:256] * w[:, None], axis=0)
    f = np.fft.rfftfreq(256, 1 / fs)
    sel = (f >= 500) & (f <= 1500)
    steer = stage.weights[None, None, :] * np.exp(-2j * np.pi * f[sel, None, None] * tau[None])
    ref = np.einsum("fbc,fc->fb", steer, spec[sel])
    assert np.max(np.abs(y[0] - ref)) < 2e-5 * np.max(np.abs(ref))


def test_complex_baseband_input_equals_real_path(rng):
    """CBF on complex baseband blocks (fc in meta) gives the same beams at f = fc + f_bb as
    the real path gives from the positive-frequency part of the signal."""
    fs, n_h, nfft = 2048.0, 16, 256
    pos = line_array(n_h, 0.75)
    x = rng.standard_normal((nfft, n_h))
    spec = np.fft.fft(x, axis=0)
    f = np.fft.fftfreq(nfft, 1 / fs)
    spec[f <= 0] = 0  # keep the positive frequencies only
    fc = 64 * fs / nfft
    xa = np.fft.ifft(spec, axis=0) * np.exp(-2j * np.pi * fc * np.arange(nfft) / fs)[:, None]
    blk = Block(xa.astype(np.complex64), Domain.TIME, 0.0, nfft / fs, fs, pos, None,
                meta=TimeMeta(0, nfft, fc))
    band = [fc - 100, fc + 100]
    st_c = CBF(nfft=nfft, hop=nfft, window="none", band=band)
    yc = next(iter(st_c.process(iter([blk]))))
    st_r, yr, _ = run_cbf(x, fs, pos, nfft=nfft, hop=nfft, window="none", band=band)
    assert np.allclose(st_c.freqs, st_r.freqs)
    assert np.max(np.abs(yc.data[0] - yr[0])) < 1e-4 * np.max(np.abs(yr))


# -- kernels against numpy references ------------------------------------------------------------
def test_kernels_against_numpy(rng):
    s_n, n_ch, nb = 3, 5, 7
    spec = (rng.standard_normal((s_n, n_ch, 9)) + 1j * rng.standard_normal((s_n, n_ch, 9)))
    spec = spec.astype(np.complex64)
    q = np.empty((s_n, 2, 4, n_ch), np.float32)
    for s in range(s_n):  # one snapshot's (F, C) spectrum at a time, split re/im
        kb.pack_bins(np.ascontiguousarray(spec[s].T), 2, q[s])
    assert np.array_equal(q[:, 0], spec[:, :, 2:6].real.transpose(0, 2, 1))
    assert np.array_equal(q[:, 1], spec[:, :, 2:6].imag.transpose(0, 2, 1))
    x2 = np.empty((4, 2 * s_n, n_ch), np.float32)  # corner turn into per-bin operands
    kb.gather_bins(q, 0, x2[:2])
    kb.gather_bins(q, 2, x2[2:])
    assert np.array_equal(x2[:, :s_n], spec[:, :, 2:6].real.transpose(2, 0, 1))
    assert np.array_equal(x2[:, s_n:], spec[:, :, 2:6].imag.transpose(2, 0, 1))
    freqs = np.array([10.0, 20.0, 35.0, 40.0])
    delays = rng.uniform(-1e-3, 1e-3, (4, n_ch))
    weights = rng.uniform(0.5, 1.5, n_ch)
    g = np.empty((4, n_ch, 8), np.float32)
    kb.steering_real(freqs, delays, weights, g)
    ref = weights[None, :, None] * np.exp(-2j * np.pi * freqs[:, None, None] * delays.T[None])
    assert np.allclose(g[:, :, 0::2], ref.real, atol=1e-6)
    assert np.allclose(g[:, :, 1::2], ref.imag, atol=1e-6)
    # unpack: beam b = sign·direction uidx[b]; compare with the complex GEMM
    uidx = np.array([0, 1, 2, 3, 0, 1, 3], np.int64)
    sign = np.array([1, 1, 1, 1, -1, -1, -1], np.float32)
    z = np.matmul(x2, g)
    y = np.zeros((s_n, 6, nb), np.complex64)
    kb.unpack_beams(z, uidx, sign, y, 1)
    xc = spec[:, :, 2:6].transpose(2, 0, 1)  # (nf, S, C)
    wc = ref[:, :, uidx]  # (nf, C, B)
    wc[:, :, sign < 0] = np.conj(wc[:, :, sign < 0])
    want = np.einsum("fsc,fcb->sfb", xc, wc)
    assert np.allclose(y[:, 1:5], want, atol=1e-4)
    assert np.all(y[:, [0, 5]] == 0)
    # abs2 and window sums
    p = np.empty(y.size, np.float32)
    kp.abs2(y.reshape(-1), p)
    assert np.allclose(p, np.abs(y.reshape(-1)) ** 2, rtol=1e-6)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 5), st.integers(0, 9), st.integers(1, 5), st.integers(1, 6),
       st.integers(0, 2**31 - 1))
def test_power_sums_against_numpy(h, t, n, step, seed):
    """kernels.beamform.power_sums: window sums over [head; |y|²] for any carried-over rows,
    window and step (blockwise and sliding), on a column range only."""
    g = np.random.default_rng(seed)
    m = 7
    head = g.random((h, m)).astype(np.float32)
    y = (g.standard_normal((t, m)) + 1j * g.standard_normal((t, m))).astype(np.complex64)
    rows = np.concatenate([head, (np.abs(y) ** 2).astype(np.float32)])
    if rows.shape[0] < n:
        return
    k = (rows.shape[0] - n) // step + 1
    out = np.full((k, m), -1.0, np.float32)
    kp.power_sums(head, y, n, step, 2, 6, out, np.empty(m))
    want = np.stack([rows[i * step:i * step + n].astype(np.float64).sum(0) for i in range(k)])
    np.testing.assert_allclose(out[:, 2:6], want[:, 2:6], rtol=1e-5)
    assert np.all(out[:, :2] == -1) and np.all(out[:, 6:] == -1)


# -- properties ----------------------------------------------------------------------------------
@settings(max_examples=12, deadline=None)
@given(a=st.floats(-3, 3), b=st.floats(-3, 3), seed=st.integers(0, 2**31 - 1),
       shift=st.integers(0, 3))
def test_linearity_and_shift_invariance(a, b, seed, shift):
    r = np.random.default_rng(seed)
    fs, n_h, nfft, hop = 1000.0, 6, 64, 32
    pos = line_array(n_h, 0.7)
    x1 = r.standard_normal((640, n_h))
    x2 = r.standard_normal((640, n_h))
    kw = dict(nfft=nfft, hop=hop, window="hann", band=[50.0, 400.0],
              beams={"start": 10.0, "stop": 170.0, "count": 17}, batch=4)
    _, y1, _ = run_cbf(x1, fs, pos, sizes=(100,), **kw)
    _, y2, _ = run_cbf(x2, fs, pos, sizes=(77,), **kw)
    _, y12, _ = run_cbf(a * x1 + b * x2, fs, pos, sizes=(300,), **kw)
    scale = np.max(np.abs(y1)) + np.max(np.abs(y2))
    assert np.max(np.abs(y12 - (a * y1 + b * y2))) < 1e-4 * scale * (1 + abs(a) + abs(b))
    # a delay of `shift` hops moves the snapshots by `shift`
    xs = np.concatenate([np.zeros((shift * hop, n_h)), x1])
    _, ys, _ = run_cbf(xs, fs, pos, sizes=(128,), **kw)
    assert np.max(np.abs(ys[shift:shift + y1.shape[0]] - y1)) < 1e-4 * np.max(np.abs(y1))


def test_shading_lowers_sidelobes_as_asked():
    """Chebyshev shading: equiripple sidelobes at the requested level; Taylor: at most it."""
    fs, nfft, n_h, dx = 4096.0, 1024, 32, 0.75
    f0 = 250 * fs / nfft
    pos = line_array(n_h, dx)
    x = tonal_plane_wave(nfft, fs, pos, 90.0, f0, c=C)
    for kind, sll in (("chebyshev", 35.0), ("taylor", 30.0)):
        stage, y, _ = run_cbf(x, fs, pos, nfft=nfft, hop=nfft, window="none",
                              band=[f0 - 1, f0 + 1],
                              beams={"start": 0.0, "stop": 180.0, "count": 3601},
                              shading=kind, sidelobe_db=sll)
        p = 10 * np.log10(np.abs(y[0, 0]) ** 2)
        p -= p.max()
        k = int(np.argmax(p))
        i = k
        while p[i + 1] < p[i]:  # walk down the main lobe to the first null
            i += 1
        side = p[i:].max()
        if kind == "chebyshev":
            assert abs(side + sll) < 0.5, side
        else:
            assert side < -sll + 0.5, side


def test_config_errors_name_the_key():
    with pytest.raises(ConfigError, match="'beams'"):
        CBF(beams={"start": 0, "stop": 190, "count": 3})
    with pytest.raises(ConfigError, match="'beams'"):
        CBF(beams={"bearing": [1, 2]})
    with pytest.raises(ConfigError, match="'shading'"):
        CBF(shading="kaiser")
    with pytest.raises(ConfigError, match="'nfft'"):
        build_chain({"stage": [{"type": "cbf", "nfft": 0}]})


@pytest.mark.parametrize("n_h,shading", [(16, "none"), (17, "taylor"), (9, "chebyshev")])
def test_folded_fast_path_equals_general_path(rng, monkeypatch, n_h, shading):
    """Uniform line arrays (odd and even N, symmetric shading) take the element-pair fold;
    it must give the same beams as the general paired GEMM."""
    import arrayproc.stages.beamform.cbf as cbf_mod
    fs = 2048.0
    pos = line_array(n_h, 0.75)
    x = rng.standard_normal((4096, n_h))
    kw = dict(nfft=256, hop=128, window="hann", band=[100.0, 900.0], shading=shading,
              beams={"start": 0.0, "stop": 180.0, "count": 37})
    st_f, y_f, _ = run_cbf(x, fs, pos, **kw)
    assert st_f.folded
    monkeypatch.setattr(cbf_mod, "symmetric_pairs", lambda rel, w: None)
    st_g, y_g, _ = run_cbf(x, fs, pos, **kw)
    assert not st_g.folded
    assert np.max(np.abs(y_f - y_g)) < 2e-5 * np.max(np.abs(y_g))
    # and both equal the complex steering applied directly
    w = time_window("hann", 256)
    spec = np.fft.rfft(x[:256] * w[:, None], axis=0)
    f = np.fft.rfftfreq(256, 1 / fs)
    sel = (f >= 100) & (f <= 900)
    ref = np.einsum("fbc,fc->fb", st_f.steering_matrix(), spec[sel])
    assert np.max(np.abs(y_f[0] - ref)) < 2e-5 * np.max(np.abs(ref))


def test_fold_kernels_against_numpy(rng):
    s_n, n_ch, nf = 3, 5, 4
    spec = (rng.standard_normal((s_n, n_ch, 8)) + 1j * rng.standard_normal((s_n, n_ch, 8)))
    spec = spec.astype(np.complex64)
    pi = np.array([0, 1, 2], np.int64)
    pj = np.array([4, 3, 2], np.int64)  # element 2 is the centre
    qs = np.empty((s_n, 2, nf, 3), np.float32)
    qd = np.empty((s_n, 2, nf, 3), np.float32)
    for s in range(s_n):
        kb.pack_fold(np.ascontiguousarray(spec[s].T), 1, pi, pj, qs[s], qd[s])
    xs = np.empty((nf, 2 * s_n, 3), np.float32)
    xd = np.empty((nf, 2 * s_n, 3), np.float32)
    kb.gather_bins(qs, 0, xs)
    kb.gather_bins(qd, 0, xd)
    x = spec[:, :, 1:5].transpose(2, 0, 1)  # (nf, S, C)
    ssum = x[:, :, pi] + np.where(pi == pj, 0, 1) * x[:, :, pj]
    sdif = np.where(pi == pj, 0, 1) * (x[:, :, pi] - x[:, :, pj])
    assert np.allclose(xs[:, :s_n], ssum.real) and np.allclose(xs[:, s_n:], ssum.imag)
    assert np.allclose(xd[:, :s_n], sdif.real) and np.allclose(xd[:, s_n:], sdif.imag)
    freqs = np.array([50.0, 80.0, 120.0, 200.0])
    delays = rng.uniform(-1e-3, 1e-3, (2, 3))
    w = rng.uniform(0.5, 1.5, 3)
    gc = np.empty((nf, 3, 2), np.float32)
    gs = np.empty((nf, 3, 2), np.float32)
    kb.steering_fold(freqs, delays, w, gc, gs)
    ph = 2 * np.pi * freqs[:, None, None] * delays.T[None]
    assert np.allclose(gc, w[None, :, None] * np.cos(ph), atol=1e-6)
    assert np.allclose(gs, w[None, :, None] * np.sin(ph), atol=1e-6)
    za, zb = np.matmul(xs, gc), np.matmul(xd, gs)
    uidx = np.array([0, 1, 1, 0], np.int64)
    sign = np.array([1, 1, -1, -1], np.float32)
    runs = kb.beam_runs(uidx, sign)
    assert runs.tolist() == [[0, 2, 0, 1, 1], [2, 2, 1, -1, -1]]
    y = np.zeros((s_n, nf, 4), np.complex64)
    kb.unpack_fold(za, zb, runs, y, 0)
    a = np.einsum("fsk,fku->fsu", ssum, gc)
    b = np.einsum("fsk,fku->fsu", sdif, gs)
    want = np.concatenate([a - 1j * b, (a + 1j * b)[:, :, ::-1]], axis=2).transpose(1, 0, 2)
    assert np.allclose(y, want, atol=1e-4)


def test_two_cbf_branches_of_the_same_shape_do_not_share_buffers(tmp_path, rng):
    """Two cbf branches on the same stream (a fan-out, each with its own FFT buffer) give the
    products each gives alone."""
    from arrayproc.chain import run_chain
    from arrayproc.io.products import ProductsWriter, read_products
    from arrayproc.io.recording import Recording
    from tests.conftest import write_recording
    fs, n_h = 1000.0, 8
    pos = line_array(n_h, 0.7)
    x = rng.standard_normal((6000, n_h)).astype(np.float32)
    rec = write_recording(tmp_path / "r.h5", x, fs=fs, positions=pos)
    branch = """
[[stage]]
type = "cbf"
name = "cbf_{k}"
input = "pass"
nfft = 128
hop = 64
batch = 8
window = "{win}"
beams = {{ start = 0.0, stop = 180.0, count = {nb} }}
[[stage]]
type = "integrate"
name = "int_{k}"
[[stage]]
type = "btr"
name = "btr_{k}"
"""
    text = ("[input]\nblock = 700\n[[stage]]\ntype = \"pass\"\n"
            + branch.format(k="a", nb=19, win="hann")
            + branch.format(k="b", nb=37, win="hamming"))
    with Recording(rec) as r, ProductsWriter(tmp_path / "p.h5") as w:
        run_chain(r, build_chain(text), w)
    g = read_products(tmp_path / "p.h5")
    for k, nb, win in (("a", 19, "hann"), ("b", 37, "hamming")):
        _, y, _ = run_cbf(x, fs, pos, nfft=128, hop=64, batch=8, window=win,
                          beams={"start": 0.0, "stop": 180.0, "count": nb})
        p = np.abs(y.astype(np.complex128)) ** 2
        n = (p.shape[0] // 8) * 8
        want = 10 * np.log10(p[:n].reshape(-1, 8, *p.shape[1:]).sum(1).sum(1) / 1e-12)
        assert np.allclose(g[f"btr_{k}"]["power_db"], want, atol=1e-3)


@settings(max_examples=25, deadline=None)
@given(st.integers(1, 7), st.integers(1, 6), st.integers(1, 9), st.integers(0, 2**31 - 1))
def test_gather_bins_is_the_corner_turn(n_snap, nf, width, seed):
    """kernels.beamform.gather_bins: (S, 2, F, W) per-snapshot pieces → (n, 2S, W) per-bin
    operands, real parts in rows 0..S-1 and imaginary parts in rows S..2S-1, for any bin
    range, equal to a numpy transpose."""
    g = np.random.default_rng(seed)
    q = g.standard_normal((n_snap, 2, nf, width)).astype(np.float32)
    f0 = int(g.integers(0, nf))
    n = int(g.integers(1, nf - f0 + 1))
    out = np.full((n, 2 * n_snap, width), np.nan, np.float32)
    kb.gather_bins(q, f0, out)
    want = q[:, :, f0:f0 + n].transpose(2, 1, 0, 3).reshape(n, 2 * n_snap, width)
    np.testing.assert_array_equal(out, want)


@settings(max_examples=25, deadline=None)
@given(st.integers(1, 9), st.integers(8, 200), st.integers(0, 60), st.integers(0, 2**31 - 1))
def test_window_frame_against_numpy(n_ch, n, offset, seed):
    """kernels.beamform.window_frame: one frame of the time-major buffer windowed into the
    (N, C) FFT input, equal to numpy slicing times the window."""
    g = np.random.default_rng(seed)
    x = g.standard_normal((n + offset + 5, n_ch)).astype(np.float32)
    w = g.standard_normal(n).astype(np.float32)
    out = np.empty((n, n_ch), np.float32)
    kb.window_frame(x, offset, w, out)
    np.testing.assert_array_equal(out, x[offset:offset + n] * w[:, None])


@pytest.mark.parametrize("threads", [1, 2, 3])
def test_output_independent_of_threads_and_batch(rng, threads):
    """Splitting a batch's snapshots over workers changes nothing but float32 rounding (BLAS
    blocks GEMMs of different row counts differently), for any batch size."""
    fs, n_h = 4096.0, 12
    pos = line_array(n_h, 0.4)
    x = rng.standard_normal((12000, n_h))
    ref = None
    for batch in (1, 4, 7, 32):
        _, y, _ = run_cbf(x, fs, pos, sizes=(777, 4000), nfft=256, hop=100, window="hann",
                          band=[200.0, 1500.0], batch=batch, threads=threads)
        if ref is None:
            ref = y
        assert y.shape == ref.shape
        assert np.max(np.abs(y - ref)) < 1e-6 * np.max(np.abs(ref))


def test_gap_in_the_stream_starts_a_new_frame_run_on_the_absolute_grid(rng):
    """A jump in ``sample0`` (a gap in the recording) ends the pending frames; frames resume at
    the next multiple of ``hop`` after the gap, none spans it, and each equals the reference."""
    fs, n_h, nfft, hop = 2048.0, 8, 256, 96
    pos = line_array(n_h, 0.5)
    x = rng.standard_normal((4000, n_h)).astype(np.float32)
    gap_at, gap = 1700, 333  # samples 1700.. of x are recorded at absolute 2033..

    def blocks():
        for a, b, s0 in ((0, 900, 0), (900, gap_at, 900), (gap_at, 3100, gap_at + gap),
                         (3100, 4000, 3100 + gap)):
            yield Block(x[a:b], Domain.TIME, s0 / fs, (b - a) / fs, fs, pos, None,
                        meta=TimeMeta(s0, b - a))

    stage = CBF(nfft=nfft, hop=hop, window="hann", band=[100.0, 900.0], batch=5)
    out = list(stage.process(blocks()))
    y = np.concatenate([o.data for o in out])
    starts = np.concatenate([o.meta.starts for o in out])
    assert np.all(starts % hop == 0)
    before = starts[starts < gap_at]
    after = starts[starts >= gap_at + gap]
    assert before.size + after.size == starts.size  # nothing starts inside the gap
    assert before[-1] + nfft <= gap_at and after[0] == -(-(gap_at + gap) // hop) * hop
    assert after[-1] + nfft <= 4000 + gap and after[-1] + hop + nfft > 4000 + gap
    w = time_window("hann", nfft)
    for s in range(starts.size):
        a = starts[s] if starts[s] < gap_at else starts[s] - gap  # index into x
        f, ref = beam_power_reference(x[a:a + nfft], fs, pos, stage.beam_axis, (100.0, 900.0),
                                      C, w)
        assert np.max(np.abs(y[s] - ref)) < 2e-5 * np.max(np.abs(ref))


@settings(max_examples=20, deadline=None)
@given(st.lists(st.integers(1, 700), min_size=1, max_size=6), st.sampled_from([64, 100, 256, 300]),
       st.integers(1, 4), st.integers(0, 2**31 - 1))
def test_frames_do_not_depend_on_how_the_stream_is_cut(sizes, hop, batch, seed):
    """The stage frames its input out of the blocks as they come (a frame that straddles
    blocks is pieced together): any cutting of the stream, blocks shorter than a frame
    included, gives the beams of the uncut stream exactly, and leaves the blocks as they were."""
    g = np.random.default_rng(seed)
    fs, n_h = 2000.0, 6
    pos = line_array(n_h, 0.5)
    x = g.standard_normal((1500, n_h)).astype(np.float32)
    stage = CBF(nfft=256, hop=hop, window="hann", band=[100.0, 700.0], batch=batch)
    whole = np.concatenate([o.data.copy() for o in stage.process(
        array_blocks(x, fs, pos, (x.shape[0],)))])
    blocks = list(array_blocks(x, fs, pos, tuple(sizes)))
    copies = [b.data.copy() for b in blocks]
    cut = np.concatenate([o.data for o in stage.process(iter(blocks))])
    np.testing.assert_array_equal(cut, whole)
    for b, c in zip(blocks, copies):
        np.testing.assert_array_equal(b.data, c)


def test_same_input_same_bytes_in_fresh_stages(rng):
    """Two fresh stages (own plans, buffers and worker split) give the same bytes: nothing in
    the path is chosen by timing."""
    fs, n_h = 4096.0, 16
    pos = line_array(n_h, 0.4)
    x = rng.standard_normal((9000, n_h))
    kw = dict(nfft=512, hop=256, window="hann", band=[200.0, 1500.0], batch=8)
    a = run_cbf(x, fs, pos, sizes=(3000,), **kw)[1]
    b = run_cbf(x, fs, pos, sizes=(3000,), **kw)[1]
    np.testing.assert_array_equal(a, b)
