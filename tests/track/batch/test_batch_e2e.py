"""End to end: simulated towed-array recording with a manoeuvre → ``process``
(bearings; delays) → ``tma`` (bearings; delays). Minutes of simulation and processing: slow
(the default tests check ``run_tma`` on synthetic products, test_batch_run.py).

Checked here: the issue's "within 3σ of the truth, σ from the CRLB" for every component of
the state at the window start, for both methods (with the default corrections for the
array's motion during the wavefront's passage and the source's emission time, `tma` keys
array_motion and retarded_time; without them the solutions were 3.5-4.6σ (bearings) and
10-17σ (delays) off, docs/validation/batch_tma.md); both give a finite CRLB, the bearings
solution keeps the true (starboard) side with a much larger mirror cost, and the two methods
agree within 3σ of the bearings CRLB."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

from arrayproc.app.commands import process, simulate, tma
from arrayproc.io.products import read_products

DATA = Path(__file__).parent / "data"


@pytest.mark.slow
def test_towed_recording_to_tma_within_3_sigma(tmp_path):
    rec = tmp_path / "rec.h5"
    simulate(str(DATA / "towed_tma_scenario.toml"), str(rec))
    with h5py.File(rec) as f:
        tt = f["truth/sources/target/time"][()]
        pos = f["truth/sources/target/position"][()]
        vel = f["truth/sources/target/velocity"][()]
    t0 = None
    est = {}
    for method, chain, cfg in (
            ("bearings", "towed_tma_chain.toml", 'method = "bearings"\ncone_gate = [5.0, 175.0]\n'),
            ("delays", "towed_tma_delays.toml", 'method = "delays"\n')):
        prod = tmp_path / f"{method}_products.h5"
        process(str(rec), str(DATA / chain), str(prod))
        c = tmp_path / f"{method}.toml"
        c.write_text("[tma]\n" + cfg)
        out = tmp_path / f"{method}_tma.h5"
        tma(str(prod), str(c), str(out))
        g = read_products(str(out))["tma"]
        t0 = float(g["t0"][0])
        est[method] = (np.array([g["x"][0], g["y"][0], g["vx"][0], g["vy"][0]]), g["crlb"][0],
                       g["cost"][0], g["cost_mirror"][0])
        assert np.all(np.isfinite(g["crlb"][0])) and np.isfinite(g["range_sigma_m"][0])
        assert _s(g["attrs"]["side"]) == ("starboard" if method == "bearings" else "")
        truth = np.array([np.interp(t0, tt, pos[:, i]) for i in range(2)]
                         + [np.interp(t0, tt, vel[:, i]) for i in range(2)])
        z = (est[method][0] - truth) / np.sqrt(np.diag(est[method][1]))
        assert np.all(np.abs(z) < 3.0), (method, z)
    xb, cb, cost_b, mirror_b = est["bearings"]
    assert mirror_b > 100 * cost_b
    xd = est["delays"][0]
    assert np.all(np.abs(xb - xd) < 3 * np.sqrt(np.diag(cb)))


def _s(v):
    return v.decode() if isinstance(v, bytes) else str(v)
