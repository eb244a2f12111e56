"""End to end on a small simulated active recording: the simulator writes ``/active``, the
reader returns it, and the chain active_beams -> matched_filter -> cfar finds the moving
target at its range (within two range cells) and range rate (within 0.5 m/s), classified
moving, and a still scatterer classified still; bracket mode on an HFM -> BPSK pair of
recordings' contacts computes fewer cells and finds the same target."""

from __future__ import annotations

import numpy as np
import pytest

import arrayproc.stages.active.detect  # noqa: F401  (registers the stage types)
import arrayproc.stages.active.matched_filter  # noqa: F401
import arrayproc.stages.active.ping_beams  # noqa: F401
from arrayproc.chain import build_chain, run_chain
from arrayproc.errors import ConfigError
from arrayproc.io.products import ProductsWriter, read_products
from arrayproc.io.recording import Recording

C = 1500.0


def scenario(kind: str = "bpsk", count: int = 2) -> dict:
    act = {"waveform": kind, "duration": 1.0, "level_db": 200.0, "interval": 4.0,
           "first": 0.5, "count": count, "offset": [20.0, 0.0, 5.0], "direct": False,
           "taper": 0.02,
           "target": [{"name": "mover", "source": "mover", "ts_db": 20.0},
                      {"name": "rock", "start": [-700.0, -800.0], "depth": 60.0,
                       "heading": 0.0, "ts_db": 20.0}]}
    if kind == "bpsk":
        act.update(fc=1500.0, bits=255)
    else:
        act.update(f0=1372.0, f1=1628.0)
    return {"recording": {"fs": 5120.0, "duration": 0.5 + 4.0 * count, "sound_speed": C,
                          "seed": 4},
            "array": {"type": "line", "n": 12, "spacing": 0.5, "depth": 60.0},
            "ownship": {"start": [0.0, 0.0], "course": 180.0, "speed": 3.0},
            "source": [{"name": "mover", "start": [600.0, -1000.0], "depth": 60.0,
                        "course": 270.0, "speed": 6.0,
                        "tonals": [{"freq": 300.0, "level_db": 80.0}]}],
            "active": act, "noise": {"level_db": 60.0}}


@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    from arrayproc.sim.run import simulate
    from arrayproc.sim.scenario import parse_scenario
    d = tmp_path_factory.mktemp("active")
    out = {}
    for kind, count in (("bpsk", 2), ("hfm", 1)):
        p = d / f"{kind}.h5"
        simulate(parse_scenario(scenario(kind, count), f"small_{kind}"), p)
        out[kind] = p
    return out


CHAIN = """
[[stage]]
type = "active_beams"
beams = {{ start = 0.0, stop = 180.0, count = 46 }}
[[stage]]
type = "matched_filter"
range_rate = {{ min = -7.0, max = 7.0 }}
{extra}
[[stage]]
type = "cfar"
pfa = 1e-6
min_range_m = 100.0
"""


def run(rec_path, out_path, extra: str = "") -> dict:
    spec = build_chain(CHAIN.format(extra=extra))
    with Recording(rec_path) as rec, ProductsWriter(out_path, source=str(rec_path)) as w:
        run_chain(rec, spec, w)
    g = read_products(out_path)
    return next(v for k, v in g.items() if k != "/" and v["kind"] in ("contacts", b"contacts"))


def truth(rec_path) -> dict:
    from arrayproc.io.truth import echo_truth
    with Recording(rec_path) as rec:
        return echo_truth(rec)


def test_recording_carries_active(recordings):
    with Recording(recordings["bpsk"]) as rec:
        a = rec.active()
    assert np.allclose(a.time, [0.5, 4.5])
    rep = a.waveforms[a.waveform[0]]
    assert rep.kind == "bpsk" and rep.bits == 255 and rep.fc == 1500.0
    assert np.isclose(rep.bandwidth, 255.0)
    assert rep.samples.size == int(np.ceil(1.0 * 5120.0)) + 1
    assert np.allclose(a.projector, [20.0, 0.0, 5.0])


def test_contacts_against_truth(recordings, tmp_path):
    con = run(recordings["bpsk"], tmp_path / "p.h5")
    tr = truth(recordings["bpsk"])
    cell = C / (2 * 255.0)  # c / (2B)
    for name, moving in (("mover", True), ("rock", False)):
        for p in (0, 1):
            k = np.flatnonzero((tr["name"] == name) & (tr["ping"] == p))[0]
            m = np.flatnonzero((con["ping"] == p)
                               & (np.abs(con["range_m"] - tr["range_array_m"][k]) < 30.0))
            assert m.size, (name, p)
            j = m[np.argmax(con["snr_db"][m])]
            assert abs(con["range_m"][j] - tr["range_array_m"][k]) < 2 * cell, (name, p)
            assert abs(con["range_rate_mps"][j] - tr["range_rate_mps"][k]) < 0.5, (name, p)
            assert abs(con["cone_deg"][j] - tr["cone_deg"][k]) < 6.0, (name, p)
            assert bool(con["moving"][j]) is moving, (name, p, con["absolute_doppler_mps"][j])


def test_hfm_gets_one_replica(recordings, tmp_path):
    con = run(recordings["hfm"], tmp_path / "h.h5")
    assert con["range_rate_mps"].size and np.all(con["range_rate_mps"] == 0.0)
    assert not np.any(con["moving"])


def test_bracket_config_errors():
    with pytest.raises(ConfigError, match="bracket"):
        build_chain(CHAIN.format(extra='bracket = { source = 3 }'))
    with pytest.raises(ConfigError, match="range_rate"):
        build_chain(CHAIN.format(extra="").replace("max = 7.0", "max = 7.0, stp = 1"))
