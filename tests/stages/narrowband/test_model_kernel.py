"""Narrowband EKF: the analytic Jacobian (thesis eq. (3.23)) against finite differences, and the
numba information-form kernel against the numpy gain-form reference."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from arrayproc.stages.narrowband import _kernels
from arrayproc.stages.narrowband.model import jacobian, measurement, phase_gradient

from .reference import ekf_reference
from .synth import C, line, tonal

X = line(16, 0.36)


@settings(max_examples=60, deadline=None)
@given(th=st.floats(0.05, math.pi - 0.05), f=st.floats(100.0, 2000.0),
       tau=st.floats(0.0, 60.0), speed=st.floats(0.0, 8.0),
       cplx=st.booleans(), sd=st.booleans())
def test_jacobian_matches_finite_differences(th, f, tau, speed, cplx, sd):
    mix = 1.3 if cplx else None
    jac = jacobian(th, f, tau, X, speed, C, mix, sd)
    # central differences, steps scaled so the phase moves by ~1e-3 rad
    gmax = np.abs(phase_gradient(th, f, tau, X, speed, C, sd)).max(axis=0)
    for i, g in enumerate(gmax):
        h = 1e-3 / max(g, 1.0)
        d = np.zeros(2)
        d[i] = h
        fd = (measurement(th + d[0], f + d[1], tau, X, speed, C, mix, sd)
              - measurement(th - d[0], f - d[1], tau, X, speed, C, mix, sd)) / (2 * h)
        scale = max(g, 1.0)
        assert np.max(np.abs(fd - jac[:, i])) <= 1e-5 * scale


def test_frequency_derivative_grows_with_time():
    """Thesis fig. 3.5: |∂h/∂f| grows linearly with the time since start (envelope 2π a τ)."""
    g1 = phase_gradient(1.0, 697.0, 1.0, X, 2.5, C)[:, 1]
    g2 = phase_gradient(1.0, 697.0, 100.0, X, 2.5, C)[:, 1]
    assert np.allclose(g2 / g1, (100.0 + X * math.cos(1.0) / C) / (1.0 + X * math.cos(1.0) / C))


@pytest.mark.parametrize("sd", [True, False])
@pytest.mark.parametrize("uniform", [True, False])
@pytest.mark.parametrize("cplx", [False, True])
def test_kernel_matches_numpy_reference(cplx, uniform, sd):
    """Same rows as the gain-form numpy EKF, for uniform spacing (phasor recursion in the
    kernel) and irregular spacing (a sine and cosine per element), with unequal noise."""
    fs = 80.0 if cplx else 1706.0
    fc = 697.5 if cplx else None
    x = X if uniform else X + np.random.default_rng(8).uniform(-0.05, 0.05, X.size)
    t = np.arange(300) / fs + 3.0
    y = tonal(t, x, 63.0, 697.0, 2.5, 0.0, seed=3, fc=fc)
    r = np.linspace(0.4, 0.6, X.size)
    q = np.array([math.radians(0.05) ** 2, 0.01 ** 2])
    x0 = np.array([math.radians(64.0), 697.1])
    p0 = np.diag([math.radians(2.0) ** 2, 0.5 ** 2])
    mix0 = 2 * np.pi * np.fmod(697.5 * t[0], 1.0) if cplx else None
    mix_step = 2 * np.pi * 697.5 / fs
    ref = ekf_reference(y, 0.2, 1 / fs, 2.5, x, C, mix0, mix_step, r, q, x0, p0, sd)
    state, cov, out = x0.copy(), p0.copy(), np.empty((t.size, 4))
    yi = np.ascontiguousarray(y.imag) if cplx else np.zeros((1, 1))
    _kernels.ekf_span(np.ascontiguousarray(y.real), yi, cplx, 0.2, 1 / fs, 2.5, x, C,
                      mix0 or 0.0, mix_step, 1 / r, q, state, cov, out, uniform,
                      1.0 if sd else 0.0)
    np.testing.assert_allclose(out[:, :2], ref[:, :2], rtol=1e-9, atol=1e-10)
    np.testing.assert_allclose(out[:, 2:], ref[:, 2:], rtol=1e-6)
    np.testing.assert_allclose(state, ref[-1, :2], rtol=1e-9)


def test_kernel_reflects_cone_at_end_fire():
    """A state pushed past 0 folds back into [0, π] (cos θ is even)."""
    fs, fc = 80.0, 697.5
    t = np.arange(200) / fs
    y = tonal(t, X, 2.0, 697.0, 0.0, 10.0, seed=4, fc=fc)
    state = np.array([math.radians(1.0), 697.0])
    cov = np.diag([math.radians(5.0) ** 2, 0.1 ** 2])
    out = np.empty((t.size, 4))
    _kernels.ekf_span(y.real.copy(), y.imag.copy(), True, 0.0, 1 / fs, 0.0, X, C, 0.0,
                      2 * np.pi * fc / fs, np.full(X.size, 10.0), np.array([1e-6, 1e-6]),
                      state, cov, out)
    assert np.all((out[:, 0] >= 0) & (out[:, 0] <= math.pi))
