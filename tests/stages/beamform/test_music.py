"""MUSIC and root-MUSIC: resolution at half a CBF beamwidth, RMSE against the stochastic
Cramér-Rao bound (Stoica & Nehorai 1990), coherent sources with spatial smoothing, and the
source count by MDL/AIC."""

from __future__ import annotations

import numpy as np
import pytest

from arrayproc.errors import ConfigError
from arrayproc.evaluate.scenarios.beamformers import (
    local_peaks,
    resolved,
    rmse_ratio,
    root_trials,
)
from arrayproc.io.geometry import line_array
from arrayproc.sim.snapshot_spectra import C, blocks, spectra
from arrayproc.stages.beamform._subspace import source_count
from arrayproc.stages.beamform.music import MUSIC

N, DX = 32, 0.75


def test_rmse_near_stochastic_crb_one_source():
    """One source, N = 12, K = 100, 10 dB: the root-MUSIC RMSE over 200 trials is within 25 %
    of the stochastic CRB (MUSIC is asymptotically efficient for one source; the Monte Carlo
    spread of an RMSE over 200 trials is about 5 %), and never below it by more than that."""
    pos = line_array(12, DX)
    ratio = rmse_ratio(pos, 900.0, [70.0], 10.0, 100, 200, seed=5)
    assert 0.85 < ratio[0] < 1.25, ratio


@pytest.mark.slow
@pytest.mark.parametrize("snr_db", [0.0, 10.0, 20.0])
@pytest.mark.parametrize("cones", [[70.0], [84.0, 96.0]])
def test_rmse_against_crb_monte_carlo(snr_db, cones):
    """Full Monte Carlo (1000 trials): one source and two sources 1.2 CBF beamwidths apart
    (N = 12); root-MUSIC within 35 % of the CRB from 0 dB per element up."""
    pos = line_array(12, DX)
    ratio = rmse_ratio(pos, 900.0, cones, snr_db, 100, 1000, seed=7)
    assert np.all(ratio > 0.9) and np.all(ratio < 1.35), ratio


def test_resolves_half_a_beamwidth(rng):
    pos = line_array(N, DX)
    freqs = np.arange(800.0, 1000.1, 5.0)
    bw = np.rad2deg(0.886 * C / (900.0 * N * DX))
    truth = [90.0 - bw / 4, 90.0 + bw / 4]
    x = spectra(pos, freqs, truth, 10.0, 10 * 64, rng)
    st = MUSIC(beams={"start": 84.0, "stop": 96.0, "count": 241}, snapshots=64, sources=2,
               output="broadband")
    out = [o.data[0, 0] for o in st.process(blocks(x, freqs, pos))]
    assert sum(resolved(p, st.beam_axis, truth) for p in out) >= 8


def test_smoothing_resolves_coherent_sources(rng):
    """Two fully coherent sources 8° apart: without smoothing the signal subspace is one
    dimensional and MUSIC misplaces them; forward-backward averaging with 4 subarrays
    restores rank 2 and both peaks are within 0.3°."""
    pos = line_array(16, DX)
    fr = np.array([900.0])
    truth = [80.0, 88.0]
    x = spectra(pos, fr, truth, 10.0, 200, rng, coherent=True)
    res = {}
    for smooth in (1, 4):
        st = MUSIC(beams={"start": 70.0, "stop": 100.0, "count": 601}, snapshots=200,
                   sources=2, smoothing=smooth, forward_backward=smooth > 1)
        p = next(iter(st.process(blocks(x, fr, pos, per_block=200)))).data[0, 0]
        res[smooth] = resolved(p, st.beam_axis, truth)
    assert res == {1: False, 4: True}


@pytest.mark.parametrize("rule", ["mdl", "aic"])
def test_source_count(rule, rng):
    """Two sources at 10 dB, N = 16, K = 200: MDL and AIC count 2 (Wax & Kailath 1985); noise
    alone: 0."""
    pos = line_array(16, DX)
    fr = np.array([700.0, 900.0])
    for cones, want in (([75.0, 100.0], 2), ([], 0)):
        x = spectra(pos, fr, cones, 10.0, 200, rng)
        r = np.einsum("kfc,kfd->fcd", x, x.conj()) / 200
        got = source_count(np.linalg.eigvalsh(r), 200, rule)
        assert np.all(got == want), (rule, got, want)


def test_spectrum_peak_equals_root(rng):
    pos = line_array(12, DX)
    est = root_trials(pos, 900.0, [70.0], 20.0, 100, 1, seed=3)[0, 0]
    fr = np.array([900.0])
    x = spectra(pos, fr, [70.0], 20.0, 100, np.random.default_rng(3))
    st = MUSIC(beams={"start": 65.0, "stop": 75.0, "count": 2001}, snapshots=100, sources=1)
    p = next(iter(st.process(blocks(x, fr, pos, per_block=100)))).data[0, 0]
    assert abs(local_peaks(p, st.beam_axis, 1)[0] - est) < 0.01


def test_refusals():
    pos = line_array(16, DX)
    st = MUSIC(snapshots=8)
    with pytest.raises(ConfigError, match="at least as many snapshots"):
        st.prepare(pos, np.array([900.0]))
    st = MUSIC(snapshots=64, root=True, sources=1)
    with pytest.raises(ConfigError, match="uniform line"):
        st.prepare(pos[[0, 1, 2, 5, 9]], np.array([900.0]))
    with pytest.raises(ConfigError, match="positive integer"):
        MUSIC(sources=0)
    with pytest.raises(ConfigError, match="no noise subspace"):
        MUSIC(sources=16).prepare(pos, np.array([900.0]))
