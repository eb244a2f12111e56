"""Reduced runs of the thesis chapter-3 delay scenarios (the full ones, 1000 trials per point
and 500 events, are those of the reproduction script)."""

from __future__ import annotations

import numpy as np
import pytest

from arrayproc.evaluate.scenarios import thesis_delay


@pytest.fixture(scope="module")
def tde():
    return thesis_delay


def test_fig315_reduced(tde):
    """W = 1000 Hz at 0 and 20 dB: above the collapse, within 25 % of the CRLB."""
    r = tde.delay_mc(50, np.array([0.0, 20.0]), 1000.0, 1000.0, seed=3)
    ratio = np.array(r["xcorr"]["ratio_to_crlb"])
    assert np.all(np.abs(ratio - 1) < 0.25), ratio


def test_fig315_collapse_reduced(tde):
    """W = 100 Hz collapses at low SNR (RMSE far above the bound) and recovers at 30 dB."""
    r = tde.delay_mc(60, np.array([-10.0, 30.0]), 100.0, 1000.0, seed=4)
    ratio = r["xcorr"]["ratio_to_crlb"]
    assert ratio[0] > 10 and abs(ratio[1] - 1) < 0.3


def test_phat_echo_reduced(tde):
    r = tde.phat_echo(30, seed=5)
    assert abs(r["phat"]["bias_s"]) < 0.1 * abs(r["none"]["bias_s"])
    assert r["phat"]["rmse_s"] < 0.5 * r["none"]["rmse_s"]


def test_localisation_reduced(tde):
    r = tde.localisation_mc(20, seed=6)
    assert r["localised"] == 20
    assert 0.6 < r["ratio_rmse_to_crlb"] < 1.5
    assert 1.5 < r["mean_nees"] < 4.5
