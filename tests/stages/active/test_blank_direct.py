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
from arrayproc.stages.active.ping_beams import (
    blank_direct,
    blank_selection,
    blanked_waveforms,
    direct_gate,
)

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
    from arrayproc.io.truth import echo_truth
    path = simulate_to(tmp_path, rock=True)
    with Recording(path) as rec:
        tr = echo_truth(rec)
    r_true = float(tr["range_array_m"][0])
    assert r_true < C * 1.0 / 2  # inside the direct blast's span
    cell = C / (2 * 255.0)
    found = {}
    # per waveform: the recording's only waveform is a BPSK named "bpsk"; ["hfm"] (a kind
    # with no waveform here) blanks nothing, ["bpsk"] (name and kind) what true blanks
    opts = ("", "blank_direct = true", 'blank_direct = ["bpsk"]', 'blank_direct = ["hfm"]')
    for i, blank in enumerate(opts):
        con = contacts(path, tmp_path / f"p{i}.h5", blank)
        m = np.flatnonzero(np.abs(con["range_m"] - r_true) < 2 * cell)
        found[blank] = con, m
    for blank in ("", 'blank_direct = ["hfm"]'):
        con, m = found[blank]
        assert m.size == 0  # under the plateau of the blast (~50 dB above the echo)
    for blank in ("blank_direct = true", 'blank_direct = ["bpsk"]'):
        con, m = found[blank]
        assert m.size
        j = m[np.argmax(con["snr_db"][m])]
        assert abs(con["cone_deg"][j] - tr["cone_deg"][0]) < 6.0
        assert abs(con["range_rate_mps"][j] - tr["range_rate_mps"][0]) < 0.5
        assert not bool(con["moving"][j])
    a, b = found["blank_direct = true"][0], found['blank_direct = ["bpsk"]'][0]
    np.testing.assert_array_equal(a["range_m"], b["range_m"])


def test_blank_selection_by_name_and_kind():
    from types import SimpleNamespace as NS
    wfs = {"hfm": NS(kind="hfm"), "bpsk": NS(kind="bpsk"), "long": NS(kind="bpsk")}
    w = "stage 'beams'"
    assert blanked_waveforms(blank_selection(True, w), wfs, w) == {"hfm", "bpsk", "long"}
    assert blanked_waveforms(blank_selection(False, w), wfs, w) == frozenset()
    assert blanked_waveforms(blank_selection(["bpsk"], w), wfs, w) == {"bpsk", "long"}
    assert blanked_waveforms(blank_selection(["long"], w), wfs, w) == {"long"}
    assert blanked_waveforms(blank_selection(["lfm", "hfm"], w), wfs, w) == {"hfm"}
    with pytest.raises(ConfigError, match="'bpks', neither a waveform"):
        blanked_waveforms(blank_selection(["bpks"], w), wfs, w, "r.h5")


def test_blank_only_the_listed_waveform_in_a_schedule(tmp_path):
    """An HFM/BPSK schedule: with ["bpsk"] the BPSK ping's beams lose the direct blast and the
    HFM ping's are those of the unblanked chain, bit for bit."""
    from arrayproc.sim.run import simulate
    from arrayproc.sim.scenario import parse_scenario
    d = scenario(rock=False)
    del d["noise"]
    act = d["active"]
    for k in ("waveform", "fc", "bits", "duration", "taper"):
        del act[k]
    act["waveforms"] = {"hfm": {"waveform": "hfm", "f0": 1372.0, "f1": 1628.0, "duration": 1.0,
                                "taper": 0.02},
                        "bpsk": {"waveform": "bpsk", "fc": 1500.0, "bits": 255,
                                 "duration": 1.0, "taper": 0.02}}
    act.update(schedule=["hfm", "bpsk"], interval=1.5, count=2)
    path = simulate(parse_scenario(d, "sched.toml"), tmp_path / "s.h5")
    spec = "[[stage]]\ntype = \"active_beams\"\nbeams = {{ start = 0.0, stop = 180.0, " \
        "count = 7 }}\nwindow_s = 1.4\n{blank}\n"
    out = {}
    for blank in ("", 'blank_direct = ["bpsk"]'):
        ch = build_chain(spec.format(blank=blank))
        with Recording(path) as rec:
            out[blank] = {b.meta.waveform: np.array(b.data) for b in ch.stages[0].process(
                _blocks(ch, rec))}
    raw, bl = out[""], out['blank_direct = ["bpsk"]']
    np.testing.assert_array_equal(raw["hfm"], bl["hfm"])
    e = np.sum(np.abs(raw["bpsk"]) ** 2)
    assert e > 0 and np.sum(np.abs(bl["bpsk"]) ** 2) < 1e-6 * e


def _blocks(ch, rec):
    """Bind the chain's first stage to ``rec`` and return the recording's time blocks."""
    from arrayproc.chain.graph import set_rates
    from arrayproc.chain.reader import read_blocks
    from arrayproc.chain.stage import RunContext
    ch.stages[0].bind(RunContext(products=None, sound_speed=rec.sound_speed, recording=rec))
    set_rates(ch, rec.fs)
    return read_blocks(rec, ch.block, ch.block, 0, rec.n_samples)


def test_blank_direct_config_errors(tmp_path):
    for bad in ('"yes"', "[]", "[1]", "1"):
        with pytest.raises(ConfigError, match="key 'blank_direct' must be true, false or a "):
            build_chain(CHAIN.format(blank=f"blank_direct = {bad}"))
    path = simulate_to(tmp_path, rock=False)
    with pytest.raises(ConfigError) as e:
        contacts(path, tmp_path / "x.h5", 'blank_direct = ["bpks"]')
    msg = str(e.value)
    assert "\n" not in msg and "'bpks'" in msg and "bpsk" in msg


def test_negative_margin_is_a_config_error():
    with pytest.raises(ConfigError, match="blank_margin_s"):
        build_chain(CHAIN.format(blank="blank_direct = true\nblank_margin_s = -1.0"))
