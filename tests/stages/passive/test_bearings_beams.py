"""``bearings`` on beams other than CBF: peak separation from the measured peak width, the
warning when a fixed separation is wider than the beams, and (relative-bearing beams) the
side resolved by the port/starboard rejection."""

from __future__ import annotations

import numpy as np
import pytest

from arrayproc.chain.stage import RunContext
from arrayproc.dsp.peaks import half_power_width, pick_peaks
from arrayproc.evaluate.scenarios.beamformers import Products
from arrayproc.io.geometry import line_array
from arrayproc.sim.snapshot_spectra import C, blocks, spectra
from arrayproc.stages.beamform.mvdr import MVDR
from arrayproc.stages.passive.bearings import Bearings


def test_half_power_width_of_a_gaussian():
    x = np.linspace(-10, 10, 2001)
    sig = 1.3
    y = 10 * np.log10(np.exp(-0.5 * (x / sig) ** 2))
    want = 2 * sig * np.sqrt(2 * np.log(10 ** 0.30103))  # where the power is halved
    assert abs(half_power_width(y, x, 1000) - want) < 1e-4


def test_width_separation_follows_the_peak():
    x = np.linspace(0, 20, 401)
    narrow = lambda c, w: np.exp(-0.5 * ((x - c) / w) ** 2)  # noqa: E731
    y = 10 * np.log10(narrow(8.0, 0.2) + 0.8 * narrow(9.0, 0.2) + 1e-6)
    both = pick_peaks(y, x, -20.0, 0.0, widths=2.0)
    assert [round(p, 1) for p, _, _ in both] == [8.0, 9.0]
    assert len(pick_peaks(y, x, -20.0, 4.0)) == 1  # a fixed 4 deg merges them


def mvdr_power(rng, n=32, dx=0.75):
    pos = line_array(n, dx)
    freqs = np.arange(800.0, 1000.1, 5.0)
    bw = np.rad2deg(0.886 * C / (900.0 * n * dx))
    truth = [90.0 - bw / 4, 90.0 + bw / 4]
    x = spectra(pos, freqs, truth, 10.0, 4 * 64, rng)
    st = MVDR(beams={"start": 80.0, "stop": 100.0, "count": 401}, snapshots=64)
    return truth, list(st.process(blocks(x, freqs, pos)))


def run_bearings(power_blocks, **kw):
    brg = Bearings(**kw)
    brg.ctx = RunContext(products=Products())
    list(brg.process(iter(power_blocks)))
    g = brg.ctx.products.groups["bearings"]
    return g.column("time"), g.column("cone_deg")


def test_mvdr_bearings_resolve_with_width_separation(rng):
    truth, out = mvdr_power(rng)
    t, cone = run_bearings(out, min_separation=0.0, peak_widths=1.0, threshold_db=6.0,
                           max_peaks=2)
    for tt in np.unique(t):
        got = np.sort(cone[t == tt])
        assert got.size == 2 and np.all(np.abs(got - truth) < 0.3), got
    with pytest.warns(UserWarning, match="min_separation"):
        t4, cone4 = run_bearings(out, threshold_db=6.0, max_peaks=2)
    assert all(np.sum(t4 == tt) == 1 for tt in np.unique(t4))  # 4 deg fixed: merged
