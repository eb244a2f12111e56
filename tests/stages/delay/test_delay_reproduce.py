"""Reduced runs of scripts/reproduce_tde.py (the full ones: 1000 trials per point, 500 events)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

SCRIPT = Path(__file__).resolve().parents[3] / "scripts" / "reproduce_tde.py"


@pytest.fixture(scope="module")
def script():
    spec = importlib.util.spec_from_file_location("reproduce_tde", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_fig315_reduced(script):
    """W = 1000 Hz at 0 and 20 dB: above the collapse, within 25 % of the CRLB."""
    r = script.delay_mc(50, np.array([0.0, 20.0]), 1000.0, 1000.0, seed=3)
    ratio = np.array(r["xcorr"]["ratio_to_crlb"])
    assert np.all(np.abs(ratio - 1) < 0.25), ratio


def test_fig315_collapse_reduced(script):
    """W = 100 Hz collapses at low SNR (RMSE far above the bound) and recovers at 30 dB."""
    r = script.delay_mc(60, np.array([-10.0, 30.0]), 100.0, 1000.0, seed=4)
    ratio = r["xcorr"]["ratio_to_crlb"]
    assert ratio[0] > 10 and abs(ratio[1] - 1) < 0.3


def test_phat_echo_reduced(script):
    r = script.phat_echo(30, seed=5)
    assert abs(r["phat"]["bias_s"]) < 0.1 * abs(r["none"]["bias_s"])
    assert r["phat"]["rmse_s"] < 0.5 * r["none"]["rmse_s"]


def test_localisation_reduced(script):
    r = script.localisation_mc(20, seed=6)
    assert r["localised"] == 20
    assert 0.6 < r["ratio_rmse_to_crlb"] < 1.5
    assert 1.5 < r["mean_nees"] < 4.5
