"""Incoherent integration (thesis eq. 2.22) and its noise statistics (eq. 2.24)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from arrayproc.chain import build_chain
from arrayproc.chain.block import Block
from arrayproc.chain.domains import Domain, SnapshotMeta, TimeMeta
from arrayproc.chain.memory import array_blocks
from arrayproc.errors import ConfigError
from arrayproc.io.geometry import line_array
from arrayproc.stages.beamform.cbf import CBF
from arrayproc.stages.passive.integrate import Integrate


def snapshot_blocks(y: np.ndarray, sizes, times=None, headings=None):
    """Cut (S, F, B) beam data into ('snapshot','freq','beam') blocks of the given sizes."""
    i = 0
    k = 0
    s_n = y.shape[0]
    times = np.arange(s_n, dtype=float) if times is None else times
    headings = np.zeros(s_n) if headings is None else headings
    while i < s_n:
        n = min(sizes[k % len(sizes)], s_n - i)
        dom = Domain.BEAMS if np.iscomplexobj(y) else Domain.POWER
        yield Block(y[i:i + n], dom, float(times[i]), 1.0, 100.0,
                    np.zeros((2, 3)), None, np.arange(y.shape[1], dtype=float),
                    np.arange(y.shape[2], dtype=float),
                    meta=SnapshotMeta(times[i:i + n], headings[i:i + n], 100, 0, "none", 1.0))
        i += n
        k += 1


@pytest.mark.parametrize("mode", ["blockwise", "sliding"])
@pytest.mark.parametrize("sizes", [(1,), (3, 5), (32,)])
def test_sums_match_direct_computation(rng, mode, sizes):
    s_n, n = 37, 4
    y = (rng.standard_normal((s_n, 3, 2)) + 1j * rng.standard_normal((s_n, 3, 2)))
    y = y.astype(np.complex64)
    times = np.arange(s_n) * 0.5 + 10.0
    heads = np.full(s_n, 359.0)
    heads[::2] = 1.0  # circular mean must give 0, not 180
    stage = Integrate(snapshots=n, mode=mode)
    out = list(stage.process(snapshot_blocks(y, sizes, times, heads)))
    got = np.concatenate([o.data for o in out])
    t = np.concatenate([o.meta.times for o in out])
    h = np.concatenate([o.meta.headings for o in out])
    p = np.abs(y) ** 2
    step = n if mode == "blockwise" else 1
    starts = np.arange(0, s_n - n + 1, step)
    want = np.stack([p[a:a + n].sum(0) for a in starts])
    assert got.shape == want.shape
    assert np.allclose(got, want, rtol=1e-5)
    assert np.allclose(t, [times[a:a + n].mean() for a in starts])
    assert np.all(np.minimum(h, 360 - h) < 1e-6)


@pytest.mark.parametrize("mode", ["blockwise", "sliding"])
def test_threads_split_the_cells_and_change_nothing(rng, mode):
    """With enough (freq, beam) cells the sums run on several workers, each on its part of
    the cells: the result is the single-thread one to the bit, and the direct sums."""
    y = (rng.standard_normal((21, 40, 300)) + 1j * rng.standard_normal((21, 40, 300)))
    y = y.astype(np.complex64)
    res = {}
    for th in (1, 2, 3):
        st = Integrate(snapshots=4, mode=mode, threads=th)
        res[th] = np.concatenate([o.data for o in st.process(snapshot_blocks(y, (5, 9)))])
    np.testing.assert_array_equal(res[2], res[1])
    np.testing.assert_array_equal(res[3], res[1])
    p = np.abs(y.astype(np.complex128)) ** 2
    step = 4 if mode == "blockwise" else 1
    want = np.stack([p[a:a + 4].sum(0) for a in range(0, 21 - 4 + 1, step)])
    np.testing.assert_allclose(res[1], want, rtol=1e-5)


def test_mean_option_divides_by_n(rng):
    y = rng.standard_normal((8, 2, 2)).astype(np.complex64)
    a = np.concatenate([o.data for o in Integrate(snapshots=4).process(snapshot_blocks(y, (8,)))])
    b = np.concatenate([o.data for o in Integrate(snapshots=4, mean=True).process(
        snapshot_blocks(y, (8,)))])
    assert np.allclose(a / 4, b)


@pytest.mark.parametrize("n_b", [1, 4, 10])
def test_noise_after_integration_is_gamma_n_b(n_b):
    """White Gaussian noise → CBF (rectangular window, disjoint snapshots) → sum of N_B
    snapshots: Γ(shape N_B, scale N_DFT N_H σ²) per cell (thesis eq. 2.24). Cells: one beam,
    all bins (independent for white noise), many integration windows; KS test at 1 %."""
    rng = np.random.default_rng(2024 + n_b)
    fs, nfft, n_h, sigma = 1024.0, 256, 16, 0.7
    pos = line_array(n_h, 0.75)
    n_out = 60
    x = sigma * rng.standard_normal((nfft * n_b * n_out, n_h))
    cbf = CBF(nfft=nfft, hop=nfft, window="none", band=[8.0, 500.0],
              beams={"start": 75.0, "stop": 75.0, "count": 1})
    integ = Integrate(snapshots=n_b, mode="blockwise")
    blocks = array_blocks(x, fs, pos, (4096,))
    out = np.concatenate([o.data for o in integ.process(cbf.process(blocks))])
    assert out.shape[0] == n_out
    scale = nfft * n_h * sigma**2
    samples = out[:, :, 0].ravel().astype(float) / scale
    ks = stats.kstest(samples, stats.gamma(a=n_b).cdf)
    assert ks.pvalue > 0.01, ks
    # the moments of eq. (2.24): mean N_B, variance N_B (in units of the scale)
    se = np.sqrt(n_b / samples.size)
    assert abs(samples.mean() - n_b) < 4 * se
    # and a wrong shape is rejected (the test has power)
    assert stats.kstest(samples, stats.gamma(a=n_b + 1, scale=n_b / (n_b + 1)).cdf).pvalue < 0.01


def test_rejects_time_domain_input_and_bad_keys():
    with pytest.raises(ConfigError, match="'mode'"):
        Integrate(mode="running")
    with pytest.raises(ConfigError, match="'snapshots'"):
        build_chain({"stage": [{"type": "integrate", "snapshots": 0}]})
    blk = Block(np.zeros((4, 2), np.float32), Domain.TIME, 0.0, 1.0, 4.0,
                np.zeros((2, 3)), meta=TimeMeta(0, 4))
    with pytest.raises(ConfigError, match="needs beams or power blocks"):
        list(Integrate()(iter([blk])))
    with pytest.raises(ConfigError, match="needs beams or power blocks, but its input yields time"):
        build_chain({"stage": [{"type": "integrate"}]})


def test_blockwise_groups_sit_on_the_absolute_snapshot_grid(rng):
    """A stream starting at snapshot 3 (a segment) integrates the same groups of N as the whole
    stream: groups start at multiples of N on the absolute snapshot grid."""
    hop, n = 100, 4
    y = (rng.standard_normal((20, 2, 3)) + 1j * rng.standard_normal((20, 2, 3)))
    y = y.astype(np.complex64)

    def blocks(first):
        for a in range(first, 20, 5):
            e = min(20, a + 5)
            yield Block(y[a:e], Domain.BEAMS, a * 0.1, 0.5, 1000.0,
                        np.zeros((2, 3)), None, np.arange(2.0), np.arange(3.0),
                        meta=SnapshotMeta(np.arange(a, e) * 0.1, np.zeros(e - a), 200, hop,
                                          "none", 5.0, starts=np.arange(a, e) * hop))

    whole = list(Integrate(snapshots=n).process(blocks(0)))
    part = list(Integrate(snapshots=n).process(blocks(3)))
    tw = np.concatenate([o.meta.times for o in whole])
    tp = np.concatenate([o.meta.times for o in part])
    assert np.allclose(tw[1:], tp)  # the segment lost only the group it started inside
    assert np.allclose(np.concatenate([o.data for o in whole])[1:],
                       np.concatenate([o.data for o in part]))
