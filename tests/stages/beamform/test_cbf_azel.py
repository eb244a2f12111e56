"""``cbf_azel``: the azimuth × elevation power pattern of a tetrahedral array against the closed
form |Σ_n e^{j k·r_n}|², its peak, and the lag-interpolation path against eq. (1) in numpy."""

from __future__ import annotations

import numpy as np
import pytest

from arrayproc.chain.block import Block, Pose
from arrayproc.chain.domains import Domain, TimeMeta
from arrayproc.errors import ConfigError
from arrayproc.sim.scenario import tetrahedron
from arrayproc.stages.beamform._common import SpectraFramer
from arrayproc.stages.beamform.cbf_azel import (
    CBFAzEl,
    azel_power_reference,
    lag_step,
    world_directions,
)

C = 1500.0
FS = 8000.0


def body_vector(az_deg: float, el_deg: float, heading: float = 0.0) -> np.ndarray:
    """Body-frame unit vector towards a source at true azimuth/elevation (elevation up, z down)."""
    a, e = np.deg2rad(az_deg - heading), np.deg2rad(el_deg)
    return np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), -np.sin(e)])


def tone_plane_wave(n: int, positions: np.ndarray, k: np.ndarray, freq: float,
                    amp: float = 1.0, phase: float = 0.4) -> np.ndarray:
    """x_n(t) = A cos(2π f (t + (r_n·k)/c) + φ): the element nearer the source leads."""
    t = np.arange(n) / FS
    tau = positions @ k / C
    return amp * np.cos(2 * np.pi * freq * (t[:, None] + tau[None, :]) + phase)


def blocks_of(x: np.ndarray, positions: np.ndarray, heading: float | None = None,
              size: int = 3000):
    pose = None if heading is None else Pose(np.zeros(2), heading, 0.0, 0.0, positions)
    for i in range(0, x.shape[0], size):
        s = min(size, x.shape[0] - i)
        yield Block(x[i:i + s].astype(np.float32), Domain.TIME, i / FS, s / FS, FS,
                    positions, pose, meta=TimeMeta(i, s))


def run(x, positions, heading=None, **kw):
    st = CBFAzEl(**kw)
    out = list(st.process(blocks_of(x, positions, heading)))
    return st, np.concatenate([o.data[:, 0, :] for o in out]), out


@pytest.mark.parametrize("az0, el0, heading", [(40.0, 20.0, None), (250.0, -36.0, None),
                                               (130.0, 64.0, 75.0)])
def test_tetrahedron_pattern_is_the_closed_form(az0, el0, heading):
    pos = tetrahedron(1.84)
    nfft, f0 = 512, 25 * FS / 512  # 390.625 Hz, below c/(2d): on a bin, integer cycles per frame
    k0 = body_vector(az0, el0, heading or 0.0)
    x = tone_plane_wave(4 * nfft, pos, k0, f0, amp=2.0)
    st, p, out = run(x, pos, heading, nfft=nfft, hop=nfft, window="none",
                     band=[f0 - 10, f0 + 10], azimuth=[0, 360, 2], elevation=[-90, 90, 2],
                     accuracy=1e-8)
    assert out[0].domain is Domain.POWER and out[0].meta.beam_mode == "azel"
    assert p.shape == (4, 180 * 91)
    # closed form: X_n(f0) = (N A / 2) e^{jφ} e^{j2πf0 r_n·k0/c}, so
    # P(d) = (N A/2)² |Σ_n e^{j (2π f0/c) (r_n − r̄)·(k0 − k(d))}|²
    dirs = world_directions(st.az, st.el)
    h = np.deg2rad(heading or 0.0)
    body = np.stack([dirs[:, 0] * np.cos(h) + dirs[:, 1] * np.sin(h),
                     dirs[:, 1] * np.cos(h) - dirs[:, 0] * np.sin(h), dirs[:, 2]], -1)
    rel = pos - pos.mean(0)
    ph = 2 * np.pi * f0 / C * ((k0[None, :] - body) @ rel.T)
    closed = (nfft * 2.0 / 2) ** 2 * np.abs(np.exp(1j * ph).sum(1)) ** 2
    # float32 frames, FFT and GEMM (unit roundoff 6e-8, sums of a few hundred terms): measured
    # 2.3e-7 of the coherent peak power at most; accuracy (1e-8) bounds the interpolation
    for row in p:
        np.testing.assert_allclose(row, closed, rtol=0, atol=1e-6 * closed.max())
        i = int(np.argmax(row))
        az, el = st.beam_axis[i]
        assert abs(el - el0) <= 2.0
        assert abs((az - az0 + 180) % 360 - 180) * np.cos(np.deg2rad(el0)) <= 2.0


@pytest.mark.filterwarnings("ignore:stage .cbf_azel.. key .band. reaches")
@pytest.mark.parametrize("accuracy", [1e-3, 1e-5])
def test_lag_interpolation_within_its_bound_against_numpy(rng, accuracy):
    """Broadband noise on a 6-element array: the stage against eq. (1) evaluated directly,
    within the bound of eq. (3) (accuracy × the coherent power Σ_f (Σ_n |X_n|)²) plus float32
    rounding (2e-6 of it)."""
    pos = rng.normal(0, 0.8, (6, 3))
    x = rng.normal(0, 1, (4096, 6))
    st, p, out = run(x, pos, None, nfft=1024, hop=512, window="hann", band=[50, 3000],
                     azimuth=[0, 360, 6], elevation=[-90, 90, 6], accuracy=accuracy, batch=3)
    spec_blocks = []
    fr = SpectraFramer(1024, 512, "hann", (50, 3000))
    for b in blocks_of(x, pos):
        s = fr.push(b)
        if s is not None:
            spec_blocks.append(s)
    xs = np.concatenate([s.data for s in spec_blocks])
    ref = azel_power_reference(xs, spec_blocks[0].freqs, pos, world_directions(st.az, st.el), C)
    coherent = (np.abs(xs).sum(2) ** 2).sum(1)  # (S,)
    err = np.abs(p - ref) / coherent[:, None]
    assert err.max() <= accuracy + 2e-6
    assert p.shape == ref.shape


def test_lag_step_meets_the_bound():
    d = lag_step(4000.0, 1e-4)
    assert 9 / 384 * (2 * np.pi * 4000 * d) ** 4 == pytest.approx(1e-4)


def test_config_errors():
    with pytest.raises(ConfigError, match="elevation"):
        CBFAzEl(elevation=[-100, 90, 2])
    with pytest.raises(ConfigError, match="azimuth"):
        CBFAzEl(azimuth=[0, 360])
