"""Per-bin beamformer kernel against numpy (explicit steering array), and a plane-wave pulse
steered to its cone angle."""

from __future__ import annotations

import numpy as np

from arrayproc.stages.active import _kernels as K
from arrayproc.stages.active.bank import band_plan
from arrayproc.stages.active.beamform import beam_axis, beam_series, element_advances


def test_steer_bins_matches_numpy():
    rng = np.random.default_rng(2)
    c, nk, nb = 5, 300, 7
    x = rng.standard_normal((c, nk)) + 1j * rng.standard_normal((c, nk))
    tau = rng.uniform(-3e-3, 3e-3, (nb, c))
    w = rng.uniform(0.5, 1.5, c)
    f = 900.0 + 0.25 * np.arange(nk)
    out = np.empty((nb, nk), np.complex64)
    K.steer_bins(x, 900.0, 0.25, tau, w, out)
    steer = w[None, None, :] * np.exp(-2j * np.pi * f[None, :, None] * tau[:, None, :])
    ref = np.einsum("bkc,ck->bk", steer, x)
    assert np.allclose(out, ref, rtol=1e-5, atol=1e-5 * np.abs(ref).max())


def test_plane_wave_peaks_on_its_cone():
    """A 1.5 kHz pulse arriving from cone 60 deg on a 16-element line gives its largest beam
    power on the 60 deg beam."""
    fs, c = 8000.0, 1500.0
    n_el = 16
    pos = np.zeros((n_el, 3))
    pos[:, 0] = -0.5 * np.arange(n_el)
    cone = 60.0
    adv = (pos[:, 0] - pos[:, 0].mean()) * np.cos(np.deg2rad(cone)) / c
    t = np.arange(4000) / fs
    x = np.stack([np.sin(2 * np.pi * 1500 * (t + a)) * ((t + a > 0.1) & (t + a < 0.3))
                  for a in adv], 1)
    axis, dirs, mode = beam_axis({"start": 0.0, "stop": 180.0, "count": 91})
    tau = element_advances(pos, dirs, mode, c)
    plan = band_plan(fs, x.shape[0], (1300.0, 1700.0))
    y = beam_series(x, plan, tau, np.ones(n_el))
    pw = (np.abs(y) ** 2).sum(axis=1)
    assert axis[np.argmax(pw)] == cone
