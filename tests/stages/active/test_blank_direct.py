"""``active_beams`` option ``blank_direct``: the direct blast's arrival at each element is
computed from the projector offset (|p − r_n|/c after the transmission, for the pulse length)
and zeroed; near scatterers hidden under its sidelobe plateau (thesis eq. (4.5)) become
detectable."""

from __future__ import annotations

import numpy as np
import pytest

import arrayproc.stages.active.detect  # noqa: F401  (registers the stage types)
import arrayproc.stages.active.matched_filter  # noqa: F401
from arrayproc.chain import build_chain, run_chain
from arrayproc.errors import ConfigError
from arrayproc.io.products import ProductsWriter, read_products
from arrayproc.io.recording import Recording
from arrayproc.stages.active.ping_beams import blank_direct, direct_gate

C = 1500.0
FS = 5120.0


def scenario(rock: bool) -> dict:
    act = {"waveform": "bpsk", "fc": 1500.0, "bits": 255, "duration": 1.0, "level_db": 200.0,
           "interval": 3.0, "first": 0.5, "count": 1, "offset": [20.0, 0.0, 5.0],
           "direct": True, "taper": 0.02}
    if rock:  # a still scatterer at about 400 m: its echo arrives 0.53 s after the ping,
        # while the 1 s direct blast is still being received
        act["target"] = [{"name": "rock", "start": [300.0, -260.0], "depth": 60.0,
                          "heading": 0.0, "ts_db": 20.0}]
    return {"recording": {"fs": FS, "duration": 3.5, "sound_speed": C, "seed": 5},
            "array": {"type": "line", "n": 12, "spacing": 0.5, "depth": 60.0},
            "ownship": {"start": [0.0, 0.0], "course": 180.0, "speed": 3.0},
            "active": act, "noise": {"level_db": 60.0} if rock else None}


def simulate_to(tmp_path, rock: bool):
    from arrayproc.sim.run import simulate
    from arrayproc.sim.scenario import parse_scenario
    d = scenario(rock)
    if d["noise"] is None:
        del d["noise"]
    return simulate(parse_scenario(d, "blank.toml"), tmp_path / f"r{int(rock)}.h5")


def test_gate_is_the_geometric_arrival():
    pos = np.array([[0.0, 0.0, 0.0], [-3.0, 0.0, 0.0], [0.0, 4.0, 0.0]])
    proj = np.array([20.0, 0.0, 5.0])
    first, stop = direct_gate(pos, proj, 1.0, FS, C, 0.0)
    d = np.sqrt([425.0, 554.0, 441.0]) / C
    np.testing.assert_array_equal(first, np.floor(d * FS))
    np.testing.assert_array_equal(stop, np.ceil((d + 1.0) * FS) + 1)
    x = np.ones((8000, 3))
    blank_direct(x, 0.0, pos, proj, 1.0, FS, C, 0.01)
    for ch in range(3):
        zero = np.flatnonzero(x[:, ch] == 0.0)
        assert zero[0] == np.floor((d[ch] - 0.01) * FS)
        assert zero[-1] == np.ceil((d[ch] + 1.01) * FS)
        assert zero.size == zero[-1] - zero[0] + 1


def test_blanking_removes_the_simulated_direct_blast(tmp_path):
    """No noise, no scatterer: every sample of the window is the direct blast; after the gate
    (default margin) nothing of it is left in any element."""
    path = simulate_to(tmp_path, rock=False)
    with Recording(path) as rec:
        x = rec.read(0, rec.n_samples).astype(float)
        act = rec.active()
        pos = rec.positions
    s0 = int(round(act.time[0] * FS))
    w = x[s0:].copy()
    e0 = np.sum(w ** 2)
    blank_direct(w, s0 / FS - act.time[0], pos, act.projector, 1.0, FS, C, 0.02)
    assert e0 > 0 and np.sum(w ** 2) <= 1e-12 * e0
    # without the margin only the interpolator's tails (a few samples) are left
    w = x[s0:].copy()
    blank_direct(w, s0 / FS - act.time[0], pos, act.projector, 1.0, FS, C, 0.0)
    assert np.sum(w ** 2) < 1e-3 * e0


CHAIN = """
[[stage]]
type = "active_beams"
beams = {{ start = 0.0, stop = 180.0, count = 46 }}
{blank}
[[stage]]
type = "matched_filter"
range_rate = {{ min = -3.0, max = 3.0 }}
[[stage]]
type = "cfar"
pfa = 1e-6
min_range_m = 100.0
"""


def contacts(rec_path, out_path, blank: str) -> dict:
    spec = build_chain(CHAIN.format(blank=blank))
    with Recording(rec_path) as rec, ProductsWriter(out_path, source=str(rec_path)) as w:
        run_chain(rec, spec, w)
    g = read_products(out_path)
    return next(v for k, v in g.items() if k != "/" and v["kind"] in ("contacts", b"contacts"))


def test_near_scatterer_found_only_with_blanking(tmp_path):
    from arrayproc.plots._active import echo_truth
    path = simulate_to(tmp_path, rock=True)
    with Recording(path) as rec:
        tr = echo_truth(rec)
    r_true = float(tr["range_array_m"][0])
    assert r_true < C * 1.0 / 2  # inside the direct blast's span
    cell = C / (2 * 255.0)
    found = {}
    for blank in ("", "blank_direct = true"):
        con = contacts(path, tmp_path / f"p{len(blank)}.h5", blank)
        m = np.flatnonzero(np.abs(con["range_m"] - r_true) < 2 * cell)
        found[blank] = con, m
    con, m = found[""]
    assert m.size == 0  # under the plateau of the blast (~50 dB above the echo)
    con, m = found["blank_direct = true"]
    assert m.size
    j = m[np.argmax(con["snr_db"][m])]
    assert abs(con["cone_deg"][j] - tr["cone_deg"][0]) < 6.0
    assert abs(con["range_rate_mps"][j] - tr["range_rate_mps"][0]) < 0.5
    assert not bool(con["moving"][j])


def test_negative_margin_is_a_config_error():
    with pytest.raises(ConfigError, match="blank_margin_s"):
        build_chain(CHAIN.format(blank="blank_direct = true\nblank_margin_s = -1.0"))
