"""Bearing extraction: peak picking, sub-beam interpolation, left/right bearings."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from arrayproc.chain import RunContext
from arrayproc.chain.memory import array_blocks
from arrayproc.dsp.peaks import parabolic_vertex, pick_peaks
from arrayproc.errors import ConfigError
from arrayproc.io.geometry import line_array
from arrayproc.io.products import ProductsWriter, read_products
from arrayproc.sim.plane_wave import broadband_plane_waves, tonal_plane_wave
from arrayproc.stages.beamform.cbf import CBF
from arrayproc.stages.passive.bearings import Bearings
from arrayproc.stages.passive.integrate import Integrate

C = 1500.0


def test_parabolic_vertex_exact_on_a_parabola():
    x = np.array([1.0, 2.5, 3.0])  # non-uniform
    y = -2.0 * (x - 2.3) ** 2 + 7.0
    xv, yv = parabolic_vertex(x, y)
    assert abs(xv - 2.3) < 1e-12 and abs(yv - 7.0) < 1e-12


def test_pick_peaks_threshold_separation_order():
    axis = np.arange(20.0)
    y = np.zeros(20)
    y[[3, 4, 5]] = [5, 9, 5]       # symmetric peak at 4
    y[[6, 7, 8]] = [6, 8, 3]       # a weaker peak 3 apart
    y[[14, 15, 16]] = [1, 12, 11]  # strongest, skewed towards 16
    p = pick_peaks(y, axis, floor_db=2.0, min_sep=2.5)
    assert [i for _, _, i in p] == [15, 4, 7]
    assert p[0][0] > 15.0 and p[1][0] == pytest.approx(4.0)
    assert [i for _, _, i in pick_peaks(y, axis, 2.0, 3.5)] == [15, 4]
    assert pick_peaks(y, axis, 20.0, 1.0) == []


def run_bearings(x, fs, pos, heading, tmp_path, **kw):
    cbf = CBF(nfft=512, hop=256, window="hann", band=[200.0, 900.0],
              beams={"start": 0.0, "stop": 180.0, "count": 181})
    integ = Integrate(snapshots=8, mode="blockwise")
    brg = Bearings(**kw)
    out = tmp_path / "b.h5"
    with ProductsWriter(out) as w:
        brg.bind(RunContext(products=w))
        blocks = list(array_blocks(x, fs, pos, (4096,)))

        def with_heading(bs):
            for b in bs:  # no recording: give the headings the chain would take from /nav
                heads = np.full(b.data.shape[0], heading)
                yield b.replace(meta=dataclasses.replace(b.meta, headings=heads))
        list(brg.process(with_heading(integ.process(cbf.process(iter(blocks))))))
    return read_products(out)["bearings"]


def test_broadband_bearings_and_left_right_pair(tmp_path, rng):
    fs, n_h = 2048.0, 32
    pos = line_array(n_h, 0.75)
    x = broadband_plane_waves(1 << 16, fs, pos, [70.3, 118.6], [0.5, 0.35], rng, C)
    x += 1.0 * rng.standard_normal(x.shape)  # −6 and −9 dB per hydrophone
    rows = run_bearings(x, fs, pos, 30.0, tmp_path, threshold_db=3.0, min_separation=5.0)
    n_t = np.unique(rows["time"]).size
    for cone in (70.3, 118.6):
        m = np.abs(rows["cone_deg"] - cone) < 3
        assert m.sum() == n_t  # detected in every integrated snapshot
        assert np.sqrt(np.mean((rows["cone_deg"][m] - cone) ** 2)) < 0.3
        assert np.allclose(rows["bearing_port_deg"][m], (30.0 - rows["cone_deg"][m]) % 360)
        assert np.allclose(rows["bearing_stbd_deg"][m], (30.0 + rows["cone_deg"][m]) % 360)
        assert np.all(rows["snr_db"][m] > 3.0)
    assert np.all(rows["freq_lo"] >= 200.0) and np.all(rows["freq_hi"] <= 900.0)


def test_line_bearings(tmp_path, rng):
    fs, n_h = 2048.0, 32
    pos = line_array(n_h, 0.75)
    n = 1 << 16
    x = tonal_plane_wave(n, fs, pos, 101.7, 612.0, amp=0.2, phase=0.0, c=C)
    x += rng.standard_normal(x.shape)
    rows = run_bearings(x, fs, pos, 0.0, tmp_path, broadband=False, lines=True,
                        line_threshold_db=10.0)
    assert rows["time"].size >= np.unique(rows["time"]).size
    assert np.all((rows["freq_lo"] <= 612.0) & (rows["freq_hi"] >= 612.0))
    assert np.sqrt(np.mean((rows["cone_deg"] - 101.7) ** 2)) < 0.3


def test_config_errors():
    with pytest.raises(ConfigError, match="'lines'"):
        Bearings(broadband=False, lines=False)
    with pytest.raises(ConfigError, match="'min_separation'"):
        Bearings(min_separation=-1.0)
