"""Chain engine: validation before data, branching, framing, segments."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from arrayproc.chain import Param, Stage, build_chain, register, run_chain
from arrayproc.dsp.framing import FrameBuffer
from arrayproc.errors import ConfigError
from arrayproc.io.products import ProductsWriter, read_products
from arrayproc.io.recording import Recording
from tests.conftest import write_recording

POWER = '[[stage]]\ntype = "power"\n'


@pytest.mark.parametrize("text, match", [
    ('[[stage]]\ntype = "nosuch"\n', "unknown stage type 'nosuch'"),
    ('[[stage]]\ntype = "power"\nbandd = [1.0, 2.0]\n', "unknown key 'bandd'"),
    ('[[stage]]\ntype = "power"\nband = "wide"\n', "key 'band': expected band"),
    ('[[stage]]\ntype = "power"\nband = [5.0, 1.0]\n', "lo < hi"),
    ('[[stage]]\nname = "x"\n', "missing required key 'type'"),
    ('[[stage]]\ntype = "power"\ninput = "later"\n', "names 'later'"),
    ('[[stage]]\ntype = "power"\n[[stage]]\ntype = "power"\n', "duplicate stage name"),
    ('[input]\nblock = 0\n' + POWER, "key 'block': must be > 0"),
    ('[input]\nblok = 10\n' + POWER, "unknown key 'blok'"),
    ('[output]\n' + POWER, "unknown top-level key 'output'"),
    ('', "at least one"),
    ('[[stage]\n', "invalid TOML"),
])
def test_invalid_chains_name_the_key(text, match):
    with pytest.raises(ConfigError, match=match):
        build_chain(text)


@register
class _Collect(Stage):
    """Test stage: records what it sees (block start samples), yields them on."""

    kind = "_collect"
    params = {"every": Param("int", 1)}

    def process(self, blocks):
        self.seen = []
        for i, b in enumerate(blocks):
            self.seen.append(b.meta.sample0)
            if (i + 1) % self.every == 0:
                yield b


def test_branches_see_the_same_stream_with_bounded_queues(tmp_path, rng):
    x = rng.standard_normal((100 * 64, 2)).astype(np.float32)
    p = write_recording(tmp_path / "r.h5", x)
    spec = build_chain('[input]\nblock = 64\n[[stage]]\ntype = "pass"\n'
                       '[[stage]]\ntype = "_collect"\nname = "a"\ninput = "pass"\nevery = 10\n'
                       '[[stage]]\ntype = "_collect"\nname = "b"\ninput = "pass"\n')
    # Count the longest fan-out queue seen while running.
    import arrayproc.chain as chain
    longest = [0]
    orig = chain.drive

    def spy(leaves, queues, on_block=None):
        def tick():
            longest[0] = max(longest[0], max(len(q) for qs in queues for q in qs))
        return orig(leaves, queues, tick)
    chain.drive = spy
    try:
        with Recording(p) as r:
            n = run_chain(r, spec)
    finally:
        chain.drive = orig
    a, b = spec.stages[1], spec.stages[2]
    assert n == 100 and a.seen == b.seen == [64 * k for k in range(100)]
    assert longest[0] <= 11  # bounded by one integration period, not by the file length


@settings(max_examples=40, deadline=None)
@given(n=st.integers(1, 600), cuts=st.lists(st.integers(1, 97), min_size=1, max_size=30),
       nfft=st.integers(1, 64), hop=st.integers(1, 80))
def test_framebuffer_is_independent_of_block_cuts(n, cuts, nfft, hop):
    """Frames are on the absolute sample grid whatever the reader's block boundaries."""
    x = np.arange(n * 2, dtype=np.float64).reshape(n, 2)
    fb = FrameBuffer(nfft, hop)
    frames, starts = [], []
    s, i = 0, 0
    while s < n:
        c = cuts[i % len(cuts)]
        i += 1
        f, st_ = fb.push(x[s:s + min(c, n - s)], s)
        frames.append(f)
        starts.append(st_)
        s += c
    frames = np.concatenate(frames)
    starts = np.concatenate(starts)
    k = 0 if n < nfft else (n - nfft) // hop + 1
    assert list(starts) == [hop * j for j in range(k)]
    for j, s0 in enumerate(starts):
        assert np.array_equal(frames[j], x[s0:s0 + nfft])


def run_segment(path, text, group, out, t0=None, t1=None):
    """Run a chain over [t0, t1) s of a recording (all of it by default); one products group."""
    win = None if t0 is None else (t0, t1)
    with Recording(path) as r, ProductsWriter(out, time_window=win) as w:
        run_chain(r, build_chain(text), w, t0, t1)
    return read_products(out)[group]


def test_segments_concatenate_to_the_full_run(tmp_path, rng):
    """Two segments run independently give exactly the rows of one run over the whole file."""
    x = rng.standard_normal((64 * 40, 3)).astype(np.float32)
    p = write_recording(tmp_path / "r.h5", x, fs=640.0)
    text = '[input]\nblock = 64\n' + POWER

    full = run_segment(p, text, "power", tmp_path / "full.h5")
    a = run_segment(p, text, "power", tmp_path / "a.h5", 0.0, 2.0)
    b = run_segment(p, text, "power", tmp_path / "b.h5", 2.0, 4.0)
    assert np.array_equal(np.concatenate([a["time"], b["time"]]), full["time"])
    assert np.array_equal(np.concatenate([a["power_db"], b["power_db"]]), full["power_db"])


def test_power_stage_matches_mean_square(tmp_path):
    """A 1 Pa-amplitude sine has mean square 0.5 Pa² → 10 log10(0.5 / 1e-12) dB re 1 µPa²."""
    fs = 1000.0
    t = np.arange(4000) / fs
    x = np.stack([np.sin(2 * np.pi * 50 * t), 2 * np.sin(2 * np.pi * 200 * t)], -1)
    p = write_recording(tmp_path / "r.h5", x.astype(np.float32), fs=fs)
    spec = build_chain('[input]\nblock = 1000\n[[stage]]\ntype = "power"\nband = [0.0, 500.0]\n')
    with Recording(p) as r, ProductsWriter(tmp_path / "o.h5") as w:
        run_chain(r, spec, w)
    d = read_products(tmp_path / "o.h5")["power"]
    expect = 10 * np.log10(np.array([0.5, 2.0]) / 1e-12)
    assert np.allclose(d["power_db"], expect, atol=1e-3)
    assert np.allclose(d["time"], [0.5, 1.5, 2.5, 3.5])


@pytest.mark.parametrize("mode", ["blockwise", "sliding"])
def test_segments_of_a_beamforming_chain_concatenate(tmp_path, rng, mode):
    """dft_filter (decimating) → cbf → integrate → btr: segments run independently, each with
    the chain's warm-up margin, give the rows of one run over the whole file."""
    from arrayproc.chain import warmup_margin
    from arrayproc.io.geometry import line_array
    fs = 2048.0
    x = rng.standard_normal((int(fs * 40), 8)).astype(np.float32)
    p = write_recording(tmp_path / "r.h5", x, fs=fs, positions=line_array(8, 0.75))
    text = f"""
[input]
block = 3000
[[stage]]
type = "dft_filter"
band = [100.0, 400.0]
decimate = 2
[[stage]]
type = "cbf"
nfft = 256
hop = 128
band = [100.0, 400.0]
beams = {{start = 0.0, stop = 180.0, count = 19}}
[[stage]]
type = "integrate"
snapshots = 4
mode = "{mode}"
[[stage]]
type = "btr"
"""
    spec = build_chain(text)
    with Recording(p) as r:
        assert warmup_margin(spec, r.fs) >= 4 * 128 / 1024.0 + 256 / 1024.0

    full = run_segment(p, text, "btr", tmp_path / "full.h5")
    a = run_segment(p, text, "btr", tmp_path / "a.h5", 0.0, 17.3)
    b = run_segment(p, text, "btr", tmp_path / "b.h5", 17.3, 40.0)
    assert np.allclose(np.concatenate([a["time"], b["time"]]), full["time"])
    assert np.allclose(np.concatenate([a["power_db"], b["power_db"]]), full["power_db"],
                       atol=1e-3)


def test_merge_joins_a_segment_that_found_nothing(tmp_path):
    """A segment without rows holds its kind's empty table (tau of shape (0, 0)); merged with
    a segment that has rows (n, 4) it gives that segment's rows, and the units attribute."""
    from arrayproc.chain.segments import merge_products
    parts = [tmp_path / "a.h5", tmp_path / "b.h5"]
    with ProductsWriter(parts[0], attrs={"units": "FS"}) as w:
        w.group("tde", "delays")
    tau = np.arange(12.0).reshape(3, 4)
    with ProductsWriter(parts[1], attrs={"units": "FS"}) as w:
        w.group("tde", "delays").append(time=np.arange(3.0), tau=tau, sigma=tau, corr=tau)
    merge_products(parts, tmp_path / "m.h5", "rec.h5", "")
    g = read_products(tmp_path / "m.h5")
    np.testing.assert_array_equal(g["tde"]["tau"], tau)  # copied, not computed
    assert g["/"]["units"] == "FS"
