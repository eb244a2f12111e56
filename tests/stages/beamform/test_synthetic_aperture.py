"""Inverse beamforming, passive synthetic aperture and ETAM against thesis chapter 2."""

from __future__ import annotations

import numpy as np
import pytest

from arrayproc.chain import RunContext, build_chain, run_chain
from arrayproc.chain.reader import read_blocks
from arrayproc.errors import ConfigError
from arrayproc.io.geometry import line_array
from arrayproc.io.products import ProductsWriter, read_products
from arrayproc.io.recording import Recording
from arrayproc.stages.beamform.etam import ETAM, PSAS
from arrayproc.stages.beamform.ibf import onion_peel, plane_wave
from tests.conftest import write_recording
from tests.line_synth import towed_tonals

N, DX, C, FS = 64, 0.36, 1500.0, 1024.0
F_T = 250.0  # Hz; on a DFT bin for 4 s and 8 s snapshots
LAM = C / F_T


def run_stage(stage, path):
    with Recording(path) as r:
        stage.bind(RunContext(sound_speed=C, recording=r))
        return list(stage(read_blocks(r, 8192, 8192)))


def cell(blocks, cone=90.0, f=F_T):
    """|Y|² at the given beam and bin for every output snapshot."""
    b0 = blocks[0]
    fi = int(np.argmin(np.abs(b0.freqs - f)))
    bi = int(np.argmin(np.abs(b0.beams - cone)))
    return np.array([np.abs(b.data[0, fi, bi]) ** 2 for b in blocks])


@pytest.fixture(scope="module")
def ideal(tmp_path_factory):
    """Abutting snapshots (eq. 2.32): U = N_H δx / T_B with T_B = 8 s."""
    d = tmp_path_factory.mktemp("psas")
    u = N * DX / 8.0
    sig = towed_tonals(d / "sig.h5", FS, 8 * 11, u, [(F_T, 90.0, 1.0)])
    noise = towed_tonals(d / "noise.h5", FS, 8 * 11, u, [], noise_std=1.0, seed=5)
    return sig, noise


@pytest.mark.parametrize("n_b", [2, 5, 10])
def test_psas_gain_and_beamwidth(ideal, n_b):
    """Table 2.1b: SNR gain N_B; the 3 dB beamwidth shrinks by N_B (eqs. 2.39, 2.41)."""
    sig, noise = ideal
    beams = {"start": 80.0, "stop": 100.0, "count": 801}
    band = [246.0, 254.0]

    def stage(k):
        return PSAS(snapshots=k, band=band, beams=beams)
    s_syn, s_phys = run_stage(stage(n_b), sig), run_stage(stage(1), sig)
    n_syn, n_phys = run_stage(stage(n_b), noise), run_stage(stage(1), noise)
    noise_syn = np.mean([np.mean(np.abs(b.data) ** 2) for b in n_syn])
    noise_phys = np.mean([np.mean(np.abs(b.data) ** 2) for b in n_phys])
    gain = (cell(s_syn).mean() / noise_syn) / (cell(s_phys).mean() / noise_phys)
    assert 10 * np.log10(gain) == pytest.approx(10 * np.log10(n_b), abs=1.0)

    def width(blocks):
        fi = int(np.argmin(np.abs(blocks[0].freqs - F_T)))
        p = np.abs(blocks[0].data[0, fi]) ** 2
        above = blocks[0].beams[p >= p.max() / 2]
        return above.max() - above.min()
    ratio = width(s_phys) / width(s_syn)
    assert ratio == pytest.approx(n_b, rel=0.15)
    # and the physical aperture matches eq. (2.41) at broadside
    assert width(s_phys) == pytest.approx(np.degrees(0.886 * C / (F_T * N * DX)), rel=0.03)


@pytest.fixture(scope="module")
def perturbed(tmp_path_factory):
    """Half-overlapping snapshots (eq. 2.52), lateral motion σ = 0.2 λ per snapshot."""
    d = tmp_path_factory.mktemp("etam")
    tb = 4.0
    u = (N - 1) * DX / (2 * tb)
    return towed_tonals(d / "pert.h5", FS, tb * 40, u, [(F_T, 90.0, 1.0)],
                        lateral_std=0.2 * LAM, lateral_snapshot=tb, seed=11)


def test_etam_recovers_the_gain_lost_to_lateral_motion(perturbed):
    """Fig. 2.12: PSAS loses its gain under σ = 0.2 λ; ETAM's phase correction
    (eqs. 2.53-2.54) recovers at least 80 % of the ideal gain in dB."""
    n_b = 10
    kw = dict(band=[246.0, 254.0], beams={"start": 90.0, "stop": 90.0, "count": 1})
    one = cell(run_stage(PSAS(snapshots=1, snapshot="etam", **kw), perturbed)).mean()
    psas = cell(run_stage(PSAS(snapshots=n_b, snapshot="etam", **kw), perturbed)).mean()
    etam = cell(run_stage(ETAM(snapshots=n_b, **kw), perturbed)).mean()
    ideal_db = 10 * np.log10(n_b)
    psas_db = 10 * np.log10(psas / (n_b * one))
    etam_db = 10 * np.log10(etam / (n_b * one))
    assert psas_db < ideal_db - 3.0
    assert etam_db >= 0.8 * ideal_db


def test_etam_snapshot_length_follows_the_speed(perturbed):
    """T_B = (N_H − 1) δx / (2U) (eq. 2.52) = 4 s here: 4096 samples at 1024 Hz."""
    out = run_stage(ETAM(snapshots=2, band=[246.0, 254.0],
                         beams={"start": 90.0, "stop": 90.0, "count": 1}), perturbed)
    assert out[0].meta.nfft == 4096 and out[0].meta.synthetic.rule == "etam"


def _steer(freqs, x, cone):
    return plane_wave(freqs, x, np.full(freqs.size, np.cos(np.deg2rad(cone))), C)


def test_ibf_removes_a_strong_wave_and_keeps_a_weak_one():
    """Onion peeler (2.2.3.3): a wave 30 dB above the noise at its beam is removed to the
    noise floor, sidelobes included; a wave 10 dB weaker 20° away keeps its level."""
    rng = np.random.default_rng(1)
    x = line_array(N, DX)[:, 0]
    freqs = np.linspace(240.0, 260.0, 41)
    cones = np.arange(0.0, 180.5, 0.5)
    steer = np.stack([_steer(freqs, x, t) for t in cones])

    def beam_power(X):
        return (np.abs(np.einsum("bfc,fc->bf", steer.conj(), X)) ** 2 / N).mean(1)
    a1, a2 = np.sqrt(1000.0 / N), np.sqrt(100.0 / N)  # beam power N|a|²: 30 and 20 dB
    acc = np.zeros((2, cones.size))
    for _ in range(25):
        noise = (rng.standard_normal((freqs.size, N)) + 1j * rng.standard_normal(
            (freqs.size, N))) / np.sqrt(2)
        strong = a1 * np.exp(2j * np.pi * rng.random(freqs.size))[:, None] * _steer(
            freqs, x, 61.3)
        weak = a2 * np.exp(2j * np.pi * rng.random(freqs.size))[:, None] * _steer(
            freqs, x, 81.3)
        R, removed = onion_peel(strong + weak + noise, freqs, x, DX, C, max_sources=1)
        assert len(removed) == 1 and removed[0]["cone_deg"] == pytest.approx(61.3, abs=0.2)
        acc += [beam_power(R), beam_power(weak + noise)]
    after, reference = 10 * np.log10(acc / 25)
    i1, i2 = np.argmin(np.abs(cones - 61.3)), np.argmin(np.abs(cones - 81.3))
    # at its beam: never above the level without it (LS also takes the noise along it)
    assert after[i1] <= reference[i1] + 1.0
    away = np.abs(cones - 81.3) > 10
    assert np.all(after[away] <= reference[away] + 1.0)
    assert abs(after[i2] - reference[i2]) <= 0.5


def test_ibf_sector_keeps_waves_outside(rng):
    x = line_array(N, DX)[:, 0]
    freqs = np.array([250.0])
    X = 3 * _steer(freqs, x, 30.0) + 1 * _steer(freqs, x, 170.0)
    R, removed = onion_peel(X, freqs, x, DX, C, max_sources=1, sector=(150.0, 180.0))
    assert removed[0]["cone_deg"] == pytest.approx(170.0, abs=1e-3)
    assert np.allclose(R, 3 * _steer(freqs, x, 30.0), atol=1e-6)


def test_ibf_then_etam_chain_runs_and_writes_products(tmp_path, perturbed):
    text = """
[input]
block = 8192
[[stage]]
type = "ibf"
band = [240.0, 260.0]
sector = [150.0, 180.0]
[[stage]]
type = "etam"
snapshots = 4
band = [240.0, 260.0]
beams = {start = 0.0, stop = 180.0, count = 91}
[[stage]]
type = "integrate"
snapshots = 2
[[stage]]
type = "btr"
band = [245.0, 255.0]
"""
    spec = build_chain(text)
    with Recording(perturbed) as r, ProductsWriter(tmp_path / "p.h5") as w:
        run_chain(r, spec, w)
    d = read_products(tmp_path / "p.h5")
    assert d["btr"]["power_db"].shape[1] == 91 and d["btr"]["time"].size >= 10
    assert "ibf" in d and d["ibf"]["kind"] == "ibf_removed"
    peak = d["btr"]["cone_deg"][np.argmax(d["btr"]["power_db"].mean(0))]
    assert peak == pytest.approx(90.0, abs=2.0)


def test_config_errors(tmp_path):
    with pytest.raises(ConfigError, match="key 'beams'"):
        build_chain('[[stage]]\ntype = "etam"\nbeams = {bearings = [1.0]}\n')
    with pytest.raises(ConfigError, match="key 'nfft' must be > 0"):
        build_chain('[[stage]]\ntype = "psas"\nsnapshot = "nfft"\n')
    # a static array has no speed to set the snapshot length from
    p = write_recording(tmp_path / "s.h5", np.zeros((4096, 8), np.float32), fs=FS,
                        positions=line_array(8, DX))
    with Recording(p) as r, pytest.raises(ConfigError, match="stationary"):
        st = ETAM(snapshots=2)
        st.bind(RunContext(sound_speed=C, recording=r))
        list(st(read_blocks(r, 1024, 1024)))
    # not a line array
    pos = np.random.default_rng(0).normal(size=(8, 3))
    p = write_recording(tmp_path / "v.h5", np.zeros((4096, 8), np.float32), fs=FS,
                        positions=pos)
    with Recording(p) as r, pytest.raises(ConfigError, match="line array"):
        st = ETAM(snapshots=2, snapshot="nfft", nfft=1024)
        st.bind(RunContext(sound_speed=C, recording=r))
        list(st(read_blocks(r, 1024, 1024)))


def test_etam_off_broadside_with_doppler(tmp_path):
    """Away from broadside the overlap geometry matters: the new snapshot's aft elements sit
    where the old snapshot's forward elements were. A 250 Hz source at cone 100° (received
    Doppler-shifted off its bin) still gains 10 log10 N_B through ETAM."""
    tb = 4.0
    u = (N - 1) * DX / (2 * tb)
    p = towed_tonals(tmp_path / "c.h5", FS, tb * 24, u, [(F_T, 100.0, 1.0)],
                     lateral_std=0.1 * LAM, lateral_snapshot=tb, seed=4)
    kw = dict(band=[246.0, 254.0], beams={"start": 100.0, "stop": 100.0, "count": 1})
    one = cell(run_stage(PSAS(snapshots=1, snapshot="etam", **kw), p), 100.0).mean()
    etam = cell(run_stage(ETAM(snapshots=10, **kw), p), 100.0).mean()
    assert 10 * np.log10(etam / (10 * one)) == pytest.approx(10.0, abs=0.5)


def test_etam_stage_matches_the_numpy_reference(tmp_path):
    """The whole stage (framing, sub-aperture beams, eq. 2.53-2.54 phases, combination)
    against a plain-numpy implementation of the same equations."""
    from arrayproc.stages.beamform._common import SpectraFramer
    from arrayproc.stages.beamform.etam import etam_reference
    tb = 4.0
    u = (N - 1) * DX / (2 * tb)
    p = towed_tonals(tmp_path / "c.h5", FS, tb * 13, u, [(F_T, 100.0, 1.0), (300.0, 60.0, 0.5)],
                     noise_std=0.3, seed=2)
    kw = dict(band=[240.0, 310.0], beams={"start": 0.0, "stop": 180.0, "count": 37})
    with Recording(p) as r:
        fr = SpectraFramer(4096, 4096, "none", (240.0, 310.0), r.nav)
        specs = [s for b in read_blocks(r, 8192, 8192) if (s := fr.push(b)) is not None]
    frames = [s.data[i].astype(complex) for s in specs for i in range(s.data.shape[0])]
    ours = run_stage(ETAM(snapshots=10, **kw), p)
    ref = etam_reference(frames, specs[0].freqs, specs[0].positions[:, 0], u * tb, 32, 10,
                         np.linspace(0.0, 180.0, 37), C)
    assert len(ours) == len(ref) == 4
    for o, r_ in zip(ours, ref):
        assert np.max(np.abs(o.data[0] - r_)) <= 1e-5 * np.max(np.abs(r_))
