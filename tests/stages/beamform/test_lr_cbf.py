"""``lr_cbf``: port/starboard rejection of twin and triplet arrays against the closed forms in
kd (the cross-axis aperture in wavenumbers), the cardioid weights' constraints and white-noise
gain, the adaptive option, and refusals."""

from __future__ import annotations

import numpy as np
import pytest

from arrayproc.chain.domains import Domain
from arrayproc.errors import ConfigError
from arrayproc.evaluate.scenarios.beamformers import rejection_closed_form, source_spectra
from arrayproc.io.geometry import line_array, triplet_array, twin_line_array
from arrayproc.sim.snapshot_spectra import C, blocks
from arrayproc.stages.beamform.cbf import element_delays
from arrayproc.stages.beamform.lr_cbf import LRCBF, lr_weights, mirror_correlation, null_depth

BEAMS = {"start": -179.0, "stop": 180.0, "count": 360}


@pytest.mark.parametrize("geometry", ["twin", "triplet"])
def test_mirror_correlation_closed_form(geometry):
    """ρ = cos(kd sin β) for a twin line of separation d, (1 + 2 cos(√3 k r sin β))/3 for
    triplets of radius r."""
    freqs = np.linspace(50, 3000, 40)
    rel = np.linspace(-170, 170, 35)
    k = 2 * np.pi * freqs[:, None] / C
    s = np.sin(np.deg2rad(rel))[None]
    if geometry == "twin":
        pos, want = twin_line_array(8, 0.75, 0.3), np.cos(k * 0.3 * s)
    else:
        pos, want = triplet_array(8, 0.75, 0.12), (1 + 2 * np.cos(np.sqrt(3) * k * 0.12 * s)) / 3
    got = mirror_correlation(pos, rel, freqs, C)
    assert np.max(np.abs(got - want)) < 1e-12


@pytest.mark.parametrize("geometry", ["twin", "triplet"])
@pytest.mark.parametrize("weights,loss_db", [("das", 10.0), ("cardioid", 10.0),
                                             ("cardioid", 60.0)])
def test_rejection_against_kd_matches_closed_form(geometry, weights, loss_db, rng):
    """Measured look-over-mirror beam power of a source at β = 60° (0 dB per element per bin)
    over kd = 0.07 … 1.5 against :func:`rejection_closed_form`, with the null depth γ of the
    WNG-loss cap (10 dB: shallower nulls at small kd; 60 dB: the full null everywhere here).
    1000 snapshots: each power within ~3 %, so 0.6 dB."""
    pos = twin_line_array(16, 0.75, 0.2) if geometry == "twin" else triplet_array(12, 0.75, 0.115)
    freqs = np.arange(100.0, 2000.1, 150.0)
    n, snr, b0 = pos.shape[0], 1.0, 60.0
    x = source_spectra(pos, freqs, b0, snr, 1000, rng)
    st = LRCBF(weights=weights, beams=BEAMS, wng_loss_db=loss_db)
    y = np.concatenate([o.data for o in st.process(blocks(x, freqs, pos, per_block=250))])
    p = (np.abs(y) ** 2).mean(axis=0)
    look, mirror = np.argmin(np.abs(st.beam_axis - b0)), np.argmin(np.abs(st.beam_axis + b0))
    got = 10 * np.log10(p[:, look] / p[:, mirror])
    q = np.abs(mirror_correlation(pos, np.array([b0]), freqs, C)[:, 0]) ** 2
    gamma = (np.zeros_like(q) if weights == "das"
             else null_depth(q, n, 10 * np.log10(n) - loss_db))
    if loss_db == 10.0 and weights == "cardioid":
        assert np.any(gamma < 1) and np.any(gamma == 1)
    want = rejection_closed_form(n, q, snr, gamma)
    assert np.max(np.abs(got - want)) < 0.6, np.c_[got, want]


def test_cardioid_constraints_and_wng_floor():
    """w^H a(β) = N, w^H a(−β) = 0; WNG = N(1 − |ρ|²); with ``wng_db`` the WNG never falls
    below the floor and equals it where the full null would go below."""
    pos = triplet_array(10, 0.75, 0.1)
    n = pos.shape[0]
    freqs = np.array([200.0, 600.0, 1500.0])
    rel = np.array([-120.0, -30.0, 45.0, 100.0])
    dirs = np.stack([np.cos(np.deg2rad(rel)), np.sin(np.deg2rad(rel)), 0 * rel], 1)
    a = np.exp(2j * np.pi * freqs[:, None, None] * element_delays(pos, dirs, "3d", C).T[None])
    am = np.exp(2j * np.pi * freqs[:, None, None]
                * element_delays(pos, dirs * [1, -1, 0], "3d", C).T[None])
    w = lr_weights(pos, rel, freqs, C, "cardioid")
    assert np.allclose(np.einsum("fcb,fcb->fb", w.conj(), a), n, rtol=1e-9)
    assert np.max(np.abs(np.einsum("fcb,fcb->fb", w.conj(), am))) < 1e-8 * n
    wng = n**2 / np.einsum("fcb,fcb->fb", w.conj(), w).real
    q = np.abs(mirror_correlation(pos, rel, freqs, C)) ** 2
    assert np.allclose(wng, n * (1 - q), rtol=1e-9)
    floor_db = 10 * np.log10(n) - 6.0
    wf = lr_weights(pos, rel, freqs, C, "cardioid", wng_db=floor_db)
    wng_f = 10 * np.log10(n**2 / np.einsum("fcb,fcb->fb", wf.conj(), wf).real)
    short = 10 * np.log10(n * (1 - q)) < floor_db
    assert short.any() and (~short).any()
    assert np.all(wng_f >= floor_db - 1e-9)
    assert np.allclose(wng_f[short], floor_db, atol=1e-9)


def test_adaptive_rejects_the_mirror_as_closed_form(rng):
    """MVDR on the relative-bearing beams (Groen et al. 2005's adaptive option) for a 10 dB
    source at 50° on a twin line of small kd (0.16 at 500 Hz): steered at the mirror it nulls
    the source within its distortionless constraint. Closed form for R = I + s a a^H, per bin:
    look N(1 + Ns), mirror N²/(N − s N² |ρ|²/(1 + Ns)), a rejection 1 + Ns(1 − |ρ|²) (the
    cardioid's, reached without knowing the source); delay-and-sum: (N²s + N)/(N²|ρ|²s + N).
    Band sums of 4 groups of 64 snapshots: within 1 dB."""
    pos = twin_line_array(16, 0.75, 0.1)
    n, snr = pos.shape[0], 10.0
    freqs = np.arange(400.0, 600.1, 10.0)
    x = source_spectra(pos, freqs, 50.0, snr, 256, rng)
    q = np.abs(mirror_correlation(pos, np.array([50.0]), freqs, C)[:, 0]) ** 2
    look_a = n * (1 + n * snr)
    mirror_a = n * n / (n - snr * n * n * q / (1 + n * snr))
    want = {"das": 10 * np.log10((n * n * snr + n) * q.size / np.sum(n * n * q * snr + n)),
            "adaptive": 10 * np.log10(look_a * q.size / np.sum(mirror_a))}
    for weights in ("das", "adaptive"):
        st = LRCBF(weights=weights, beams=BEAMS, snapshots=64)
        assert st.output_domain(Domain.TIME) is (Domain.POWER if weights == "adaptive"
                                                 else Domain.BEAMS)
        out = list(st.process(blocks(x, freqs, pos, per_block=64)))
        p = np.concatenate([np.abs(o.data) ** 2 if np.iscomplexobj(o.data) else o.data
                            for o in out]).mean(axis=0).sum(axis=0)
        assert out[0].meta.beam_mode == "lr"
        look = np.argmin(np.abs(st.beam_axis - 50.0))
        mirror = np.argmin(np.abs(st.beam_axis + 50.0))
        got = 10 * np.log10(p[look] / p[mirror])
        assert abs(got - want[weights]) < 1.0, (weights, got, want[weights])
    assert want["adaptive"] > want["das"] + 8.0


def test_refusals():
    with pytest.raises(ConfigError, match="off the array axis"):
        st = LRCBF()
        list(st.process(blocks(np.zeros((4, 2, 8), complex), np.array([100.0, 200.0]),
                               line_array(8, 0.75))))
    with pytest.raises(ConfigError, match="-180 < start"):
        LRCBF(beams={"start": 0.0, "stop": 270.0, "count": 10})
