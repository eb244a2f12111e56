"""Recording files: write/read round trips, block tiling, gains/dead channels, pose."""

from __future__ import annotations

import h5py
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from arrayproc.chain.reader import count_blocks, read_blocks
from arrayproc.errors import FormatError
from arrayproc.io.geometry import body_to_world, line_array, read_geometry_xml
from arrayproc.io.recording import Recording
from tests.conftest import write_recording


@settings(max_examples=40, deadline=None)
@given(n=st.integers(1, 700), ch=st.integers(1, 5), nfft=st.integers(1, 300),
       hop_frac=st.floats(0.05, 1.0), chunk=st.integers(1, 257), seed=st.integers(0, 2**31))
def test_write_read_identical_and_blocks_tile(tmp_path_factory, n, ch, nfft, hop_frac, chunk,
                                              seed):
    """Any block size, hop and chunking: samples read back bit-identical, the blocks' heads
    (the last block's valid part) tile the file exactly, and every block equals the file
    slice it claims to be."""
    hop = max(1, int(round(nfft * hop_frac)))
    x = np.random.default_rng(seed).standard_normal((n, ch)).astype(np.float32)
    p = write_recording(tmp_path_factory.mktemp("r") / "r.h5", x, chunk_samples=chunk)
    with Recording(p) as r:
        assert np.array_equal(r.read(), x)
        blocks = list(read_blocks(r, nfft, hop))
        assert len(blocks) == count_blocks(r, nfft, hop)
        heads = []
        for k, b in enumerate(blocks):
            s = k * hop
            assert b.meta.sample0 == s
            assert b.data.shape == (nfft, ch)
            nv = b.meta.n_valid
            assert np.array_equal(b.data[:nv], x[s:s + nfft])
            assert not b.data[nv:].any()
            assert b.t0 == pytest.approx(s / r.fs)
            heads.append(b.data[:nv] if k == len(blocks) - 1 else b.data[:hop])
        assert np.array_equal(np.concatenate(heads), x)
        assert blocks[-1].meta.sample0 + nfft >= n  # the last block reaches the end
        assert len(blocks) == 1 or blocks[-2].meta.sample0 + nfft < n


def test_blocks_cross_slab_boundaries(tmp_path, monkeypatch, rng):
    """Tiny slabs force many hyperslab reads; the blocks must not change."""
    import arrayproc.chain.reader as rec
    x = rng.standard_normal((5000, 3)).astype(np.float32)
    p = write_recording(tmp_path / "r.h5", x)
    with Recording(p) as r:
        ref = [b.data.copy() for b in read_blocks(r, 256, 100)]
    monkeypatch.setattr(rec, "SLAB_BYTES", 64)
    with Recording(p) as r:
        got = [b.data for b in read_blocks(r, 256, 100)]
    assert len(ref) == len(got) and all(np.array_equal(a, b) for a, b in zip(ref, got))


def test_gains_applied_and_dead_channels_dropped(tmp_path, rng):
    x = rng.standard_normal((1000, 4)).astype(np.float32)
    pos = line_array(4, 1.0)
    p = write_recording(tmp_path / "r.h5", x, positions=pos)
    with h5py.File(p, "a") as f:
        f["array/gains"] = [1.0, 2.0, 0.5, 3.0]
        f["array/dead"] = [False, True, False, False]
    with Recording(p) as r:
        assert r.n_channels == 3 and list(r.channels) == [0, 2, 3]
        assert np.allclose(r.positions, pos[[0, 2, 3]])
        b = next(read_blocks(r, 1000))
        assert np.allclose(b.data, x[:, [0, 2, 3]] * np.array([1.0, 0.5, 3.0], np.float32))


def test_pose_interpolation_continuous_across_north(tmp_path):
    """Heading 350° → 10° interpolates through 0°, never through 180°."""
    x = np.zeros((2000, 2), np.float32)
    nav = dict(time=np.array([0.0, 2.0]), position=np.array([[0.0, 0.0], [0.0, 20.0]]),
               heading=np.array([350.0, 10.0]))
    p = write_recording(tmp_path / "r.h5", x, nav=nav, positions=line_array(2, 1.0))
    with Recording(p) as r:
        t = np.linspace(0, 2, 201)
        _, hd, _, spd = r.nav.at(t)
        d = (hd - 350.0) % 360.0
        assert np.allclose(d, 10.0 * t, atol=1e-9)  # 350 + 10 t, wrapped
        assert np.allclose(spd, 10.0)
        pose = r.pose(1.0)
        assert pose.heading == pytest.approx(0.0, abs=1e-9) or pose.heading == pytest.approx(360)
        assert np.allclose(pose.position, [0.0, 10.0])
        # heading 0: element 0 (forward, +0.5 m body x) lies north of the reference point
        assert np.allclose(pose.elements[0, :2], [0.0, 10.5])


@settings(max_examples=60, deadline=None)
@given(h0=st.floats(0, 360, exclude_max=True), dh=st.floats(-170, 170),
       frac=st.floats(0, 1))
def test_heading_interpolation_is_the_short_arc(h0, dh, frac):
    from arrayproc.geo.nav import Nav
    nav = Nav(np.array([0.0, 1.0]), np.zeros((2, 2)), np.array([h0, (h0 + dh) % 360.0]))
    _, hd, _, _ = nav.at(frac)
    expect = (h0 + frac * dh) % 360.0
    diff = (hd[0] - expect + 180.0) % 360.0 - 180.0
    assert abs(diff) < 1e-6


@settings(max_examples=50, deadline=None)
@given(h=st.floats(-720, 720), x=st.floats(-50, 50), y=st.floats(-50, 50))
def test_body_to_world_is_a_rotation(h, x, y):
    """Distances are preserved; heading h puts body +x on true bearing h, body +y on h + 90."""
    pos = np.array([[x, y, 1.0], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    w = body_to_world(pos, np.array([100.0, -3.0]), h, depth=5.0)
    assert np.isclose(np.hypot(*(w[0, :2] - w[1, :2])), np.hypot(x, y))
    assert np.isclose(w[0, 2], 6.0)
    fwd, stb = w[2, :2] - w[1, :2], w[3, :2] - w[1, :2]
    assert np.isclose(np.degrees(np.arctan2(fwd[0], fwd[1])) % 360, h % 360, atol=1e-7) or \
        np.isclose(abs(np.degrees(np.arctan2(fwd[0], fwd[1])) % 360 - h % 360), 360, atol=1e-7)
    assert np.isclose(np.degrees(np.arctan2(stb[0], stb[1])) % 360, (h + 90) % 360,
                      atol=1e-7) or np.isclose(
        abs(np.degrees(np.arctan2(stb[0], stb[1])) % 360 - (h + 90) % 360), 360, atol=1e-7)


def test_acoular_layout_with_xml_geometry(tmp_path, rng):
    """A file with only /time_data + sample_freq opens; geometry comes from acoular's XML."""
    x = rng.standard_normal((300, 3))
    p = tmp_path / "ac.h5"
    with h5py.File(p, "w") as f:
        d = f.create_dataset("time_data", data=x)
        d.attrs["sample_freq"] = 51200.0
    xml = tmp_path / "mics.xml"
    xml.write_text('<?xml version="1.0"?>\n<MicArray name="t">\n'
                   '  <pos Name="Point 1" x="0.1" y="0" z="0"/>\n'
                   '  <pos Name="Point 2" x="-0.1" y="0.2" z="0"/>\n'
                   '  <pos Name="Point 3" x="0" y="-0.2" z="0.05"/>\n</MicArray>\n')
    pos = read_geometry_xml(xml)
    with Recording(p, positions=pos) as r:
        assert r.layout == "acoular" and r.format_version is None
        assert r.sound_speed == 1500.0 and r.fs == 51200.0
        assert np.allclose(r.read(dtype=np.float64), x)
        assert np.allclose(r.positions, [[0.1, 0, 0], [-0.1, 0.2, 0], [0, -0.2, 0.05]])
    with pytest.raises(FormatError, match="no /array/positions"):
        Recording(p)


def test_line_array_geometry():
    pos = line_array(5, 0.5)
    assert np.allclose(pos[:, 0], [1.0, 0.5, 0.0, -0.5, -1.0]) and not pos[:, 1:].any()


def test_nan_policy_zero_counts(tmp_path):
    x = np.ones((100, 2), np.float32)
    x[10, 1] = np.nan
    x[50, 0] = np.inf
    p = write_recording(tmp_path / "r.h5", x)
    with Recording(p) as r, pytest.raises(FormatError, match="sample 10, channel 1"):
        list(read_blocks(r, 32))
    with Recording(p, nan="zero") as r:
        data = np.concatenate([b.data for b in read_blocks(r, 32)])[:100]
        assert r.n_nonfinite == 2 and data[10, 1] == 0 and data[50, 0] == 0


def _half_grown_nav(path, lengths: dict, fill_last: bool) -> None:
    """A live recording whose /nav datasets a writer is growing: ``lengths`` rows each, the
    last row of the longest ones still the fill value when ``fill_last``."""
    from arrayproc.io.recording_writer import RecordingWriter
    pos = np.zeros((2, 3))
    pos[1, 0] = -1.0
    with RecordingWriter(path, 1000.0, 2, positions=pos, live=True, chunk_samples=64) as w:
        w.append(np.zeros((4000, 2), np.float32))
        g = w._f.create_group("nav")
        for k, shape in (("time", ()), ("position", (2,)), ("heading", ())):
            n = lengths[k]
            d = g.create_dataset(k, shape=(n,) + shape, maxshape=(None,) + shape,
                                 dtype=float, chunks=(8,) + shape, fillvalue=np.nan)
            m = n - 1 if fill_last and n == max(lengths.values()) else n
            if k == "time":
                d[:m] = np.arange(m, dtype=float)
            elif k == "position":
                d[:m] = np.c_[2.0 * np.arange(m), np.zeros(m)]
            else:
                d[:m] = 90.0


@pytest.mark.parametrize("lengths,fill_last,rows", [
    ({"time": 3, "position": 4, "heading": 4}, True, 3),    # time not grown yet
    ({"time": 4, "position": 3, "heading": 4}, False, 3),   # position not grown yet
    ({"time": 4, "position": 4, "heading": 4}, True, 3),    # grown, last row not written
    ({"time": 4, "position": 4, "heading": 4}, False, 4),   # a whole row
])
def test_follower_reads_the_nav_rows_a_live_writer_finished(tmp_path, lengths, fill_last,
                                                            rows):
    """A follower (SWMR reader) opening a recording while its writer is between growing one
    /nav dataset and the next reads the rows every dataset holds, never a half-written row;
    a reader of a finished file refuses the same file in one clear line."""
    p = tmp_path / "rec.h5"
    _half_grown_nav(p, lengths, fill_last)
    with Recording(p, swmr=True) as r:
        assert r.nav.time.size == rows
        assert np.array_equal(r.nav.time, np.arange(rows, dtype=float))
        assert np.all(np.isfinite(r.nav.position))
    if rows == 3:
        with pytest.raises(FormatError, match="/nav"):
            Recording(p)
