"""Numba kernels of synthetic aperture processing against plain numpy references."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from arrayproc.stages.beamform import _sa_kernels as ks


def ref_subaperture(x, freqs, u, x0, dx, c):
    xn = x0 - dx * np.arange(x.shape[1])
    steer = np.exp(-2j * np.pi * freqs[:, None, None] * xn[None, None, :] * u[None, :, None] / c)
    return np.einsum("fbc,fc->fb", steer, x)


def ref_combine(beams, phase, disp, freqs, u, c):
    w = np.exp(1j * phase)[:, :, None] * np.exp(
        -2j * np.pi * freqs[None, :, None] * disp[:, None, None] * u[None, None, :] / c)
    return (beams * w).sum(0)


def ref_etam(xa, xb, shift, q):
    n_f, n_c = xa.shape
    a, b = xa[:, : n_c - shift], xb[:, shift:]
    out = np.empty(n_f)
    for f in range(n_f):
        lo, hi = max(0, f - q // 2), min(n_f, f + q // 2 + 1)
        num = np.abs((a[lo:hi] * b[lo:hi].conj()).sum(0))
        den = np.sqrt((np.abs(a[lo:hi]) ** 2).sum(0) * (np.abs(b[lo:hi]) ** 2).sum(0))
        rho = np.where(den > 0, num / np.where(den > 0, den, 1), 0.0)
        out[f] = np.angle((rho * a[f] * b[f].conj()).sum() / rho.sum())
    return out


def cgauss(rng, shape):
    return rng.standard_normal(shape) + 1j * rng.standard_normal(shape)


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 10**6), n_f=st.integers(1, 40), n_c=st.integers(2, 40),
       n_b=st.integers(1, 30))
def test_subaperture_beams_matches_numpy(seed, n_f, n_c, n_b):
    rng = np.random.default_rng(seed)
    x = cgauss(rng, (n_f, n_c)).astype(np.complex64)
    freqs = rng.uniform(10, 2000, n_f)
    u = np.cos(np.deg2rad(rng.uniform(0, 180, n_b)))
    x0, dx = 0.5 * (n_c - 1) * 0.36, 0.36
    out = np.empty((n_f, n_b), np.complex64)
    ks.subaperture_beams(x, freqs, u, x0, dx, 1500.0, out)
    ref = ref_subaperture(x.astype(np.complex128), freqs, u, x0, dx, 1500.0)
    assert np.allclose(out, ref, rtol=1e-4, atol=1e-4 * np.abs(ref).max())


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 10**6), n_s=st.integers(1, 12), n_f=st.integers(1, 600),
       n_b=st.integers(1, 20))
def test_combine_subapertures_matches_numpy(seed, n_s, n_f, n_b):
    rng = np.random.default_rng(seed)
    beams = cgauss(rng, (n_s, n_f, n_b)).astype(np.complex64)
    freqs = 100.0 + 0.25 * np.arange(n_f)
    phase = rng.uniform(-np.pi, np.pi, (n_s, n_f))
    disp = np.cumsum(rng.uniform(5, 12, n_s)) - 5
    u = np.cos(np.deg2rad(rng.uniform(0, 180, n_b)))
    out = np.empty((n_f, n_b), np.complex64)
    # the kernel reads a ring (slots in any order), beam-major
    order = rng.permutation(n_s)
    ring = np.empty((n_s, n_b, n_f), np.complex64)
    ring[order] = beams.transpose(0, 2, 1)
    ks.combine_subapertures(ring, order, np.exp(1j * phase), disp, freqs, u, 1500.0, out)
    ref = ref_combine(beams.astype(np.complex128), phase, disp, freqs, u, 1500.0)
    assert np.allclose(out, ref, rtol=1e-4, atol=1e-4 * n_s)


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 10**6), n_f=st.integers(1, 60), n_c=st.integers(2, 40),
       q=st.sampled_from([1, 3, 5, 9]), frac=st.floats(0.1, 0.9))
def test_etam_phase_matches_numpy(seed, n_f, n_c, q, frac):
    rng = np.random.default_rng(seed)
    shift = max(1, min(n_c - 1, int(frac * n_c)))
    xa = cgauss(rng, (n_f, n_c))
    xb = cgauss(rng, (n_f, n_c))
    out = np.empty(n_f)
    ks.etam_phase(xa, xb, shift, q, out)
    ref = ref_etam(xa, xb, shift, q)
    d = np.angle(np.exp(1j * (out - ref)))
    assert np.allclose(d, 0.0, atol=1e-8)


def test_etam_phase_recovers_a_common_phase_jump():
    """Shared elements see the same field; a phase jump ψ of the later snapshot comes back."""
    rng = np.random.default_rng(3)
    n_f, n_c, shift = 50, 32, 16
    field = cgauss(rng, (n_f, n_c + shift))  # the field at points 0 .. n_c + shift − 1, fore → aft
    psi = rng.uniform(-np.pi, np.pi, n_f)
    # Snapshot b's element n sits at point n + shift; snapshot b+1 moved `shift` points forward,
    # so its element n sits at point n, and its element n + shift where b's element n was; it
    # is seen with a phase jump −ψ.
    xa = field[:, shift:shift + n_c]
    xb = field[:, :n_c] * np.exp(-1j * psi)[:, None]
    out = np.empty(n_f)
    ks.etam_phase(xa, xb, shift, 5, out)
    assert np.allclose(np.angle(np.exp(1j * (out - psi))), 0.0, atol=1e-9)


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 10**6), n_f=st.integers(1, 40), n_c=st.integers(2, 40))
def test_beam_at_matches_numpy(seed, n_f, n_c):
    rng = np.random.default_rng(seed)
    x = cgauss(rng, (n_f, n_c))
    freqs = rng.uniform(10, 2000, n_f)
    u = rng.uniform(-1, 1, n_f)
    x0, dx = 3.0, 0.5
    out = np.empty(n_f, complex)
    ks.beam_at(x, freqs, u, x0, dx, 1500.0, out)
    xn = x0 - dx * np.arange(n_c)
    ref = (x * np.exp(-2j * np.pi * freqs[:, None] * xn[None] * u[:, None] / 1500.0)).sum(1)
    assert np.allclose(out, ref, rtol=1e-9, atol=1e-9 * np.abs(ref).max())


def _signatures(freqs, u, x0, dx, n_c, c=1500.0):
    xn = x0 - dx * np.arange(n_c)
    return np.exp(2j * np.pi * freqs[:, None, None] * u[None, :, None] * xn[None, None, :] / c)


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 10**6), n_f=st.integers(1, 50), n_c=st.integers(16, 40),
       n_k=st.integers(1, 3))
def test_plane_wave_fit_and_removal_match_numpy(seed, n_f, n_c, n_k):
    """Well-separated waves on enough elements (the kernel's tiny diagonal loading only
    matters for near-singular systems, where lstsq answers differently by design)."""
    rng = np.random.default_rng(seed)
    freqs = rng.uniform(200, 500, n_f)
    u = np.linspace(-0.7, 0.7, n_k) + rng.uniform(-0.05, 0.05, n_k)
    x0, dx = 0.5 * (n_c - 1) * 0.5, 0.5
    V = _signatures(freqs, u, x0, dx, n_c)  # (F, K, C)
    X = cgauss(rng, (n_f, n_c))
    A = np.empty((n_f, n_k), complex)
    H = np.empty((n_f, n_k, n_k))
    g = np.empty((n_f, n_k))
    ks.plane_wave_fit(X, freqs, u, x0, dx, 1500.0, A, H, g)
    remove = rng.random(n_k) < 0.5
    out = np.empty_like(X)
    A2 = np.empty_like(A)
    ks.remove_plane_waves(X, freqs, u, remove, x0, dx, 1500.0, out, A2)
    xn = x0 - dx * np.arange(n_c)
    for f in range(n_f):
        M = V[f].T  # (C, K)
        a = np.linalg.lstsq(M, X[f], rcond=None)[0]
        assert np.allclose(A[f], a, atol=1e-6 * (1 + np.abs(a).max()))
        assert np.allclose(A2[f], a, atol=1e-6 * (1 + np.abs(a).max()))
        r = X[f] - M @ a
        J = -(a[None, :] * (2j * np.pi * freqs[f] / 1500.0 * xn)[:, None] * M)
        h_ref, g_ref = (J.conj().T @ J).real, (J.conj().T @ r).real
        assert np.allclose(H[f], h_ref, rtol=1e-6, atol=1e-8 * np.abs(h_ref).max())
        assert np.allclose(g[f], g_ref, rtol=1e-6, atol=1e-8 * (np.abs(h_ref).max() + 1))
        assert np.allclose(out[f], X[f] - M[:, remove] @ a[remove], atol=1e-6)
