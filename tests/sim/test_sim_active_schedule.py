"""Several waveforms and a ping schedule in the scenario's [active] section: parsing, the
replicas and schedule written to /active (docs/formats.md) and /truth, and the rendered
pulses following the schedule (each ping its own waveform and source level)."""

from __future__ import annotations

import copy

import h5py
import numpy as np
import pytest

from arrayproc.errors import ConfigError
from arrayproc.io.recording import Recording
from arrayproc.sim.run import Simulator, simulate
from arrayproc.sim.scenario import parse_scenario

C = 1500.0
FS = 5120.0


def scenario(**active) -> dict:
    act = {"level_db": 200.0, "schedule": ["hfm", "bpsk"], "interval": 1.5, "first": 0.2,
           "offset": [10.0, 0.0, 0.0], "direct": True,
           "waveforms": {"hfm": {"waveform": "hfm", "f0": 1300.0, "f1": 1700.0,
                                 "duration": 0.5, "taper": 0.05, "level_db": 190.0},
                         "bpsk": {"waveform": "bpsk", "fc": 1500.0, "bits": 255,
                                  "duration": 0.5, "taper": 0.05}}}
    act.update(active)
    return {"recording": {"fs": FS, "duration": 6.0, "sound_speed": C, "seed": 3},
            "array": {"type": "line", "n": 1, "spacing": 1.0, "depth": 50.0},
            "ownship": {"start": [0.0, 0.0], "heading": 0.0},
            "active": act}


def test_schedule_cycles_names_at_interval():
    a = parse_scenario(scenario(), "s.toml").active
    t, names = a.pings(6.0)
    np.testing.assert_allclose(t, 0.2 + 1.5 * np.arange(4))
    assert names == ["hfm", "bpsk", "hfm", "bpsk"]
    assert a.levels == {"hfm": 190.0, "bpsk": 200.0}  # own level, else [active].level_db
    a = parse_scenario(scenario(schedule=["bpsk", "bpsk", "hfm"], count=4), "s.toml").active
    assert a.pings(100.0)[1] == ["bpsk", "bpsk", "hfm", "bpsk"]


def test_explicit_times():
    d = scenario(times=[0.3, 0.9, 4.0, 7.0])
    for k in ("interval", "first"):
        del d["active"][k]
    t, names = parse_scenario(d, "s.toml").active.pings(6.0)
    np.testing.assert_allclose(t, [0.3, 0.9, 4.0])  # 7 s is past the end
    assert names == ["hfm", "bpsk", "hfm"]


def test_single_waveform_form_unchanged():
    d = scenario()
    d["active"] = {"waveform": "bpsk", "fc": 1500.0, "bits": 255, "duration": 0.5,
                   "level_db": 200.0, "interval": 2.0, "first": 0.5}
    a = parse_scenario(d, "s.toml").active
    assert list(a.waveforms) == ["bpsk"] and a.schedule == ["bpsk"]
    assert a.waveform is a.waveforms["bpsk"]
    t, names = a.pings(6.0)
    np.testing.assert_allclose(t, [0.5, 2.5, 4.5])
    assert names == ["bpsk"] * 3


@pytest.mark.parametrize("change, words", [
    ({"schedule": ["hfm", "lfm"]}, "'lfm' is not a waveform"),
    ({"schedule": []}, "non-empty list of waveform names"),
    ({"schedule": None}, "schedule: missing"),
    ({"waveform": "bpsk"}, "not both"),
    ({"interval": 0.4}, "lasts past the next ping"),
    ({"times": [0.1, 0.3]}, "not used with explicit times"),
    ({"waveforms": {}}, "one or more [active.waveforms.<name>]"),
    ({"waveforms": {"a/b": {"waveform": "cw", "fc": 1000.0, "duration": 0.1}}},
     "must be a plain name"),
    ({"waveforms": {"x": {"waveform": "bpsk", "fc": 1000.0, "duration": 2.0, "bit": 255}}},
     "unknown key 'bit'"),
    ({"waveforms": {"x": {"waveform": "hfm", "f0": 1300.0, "f1": 3000.0, "duration": 0.5}}},
     "above the simulator's band"),
])
def test_config_errors_are_one_line(change, words):
    d = scenario()
    for k, v in change.items():
        if v is None:
            del d["active"][k]
        else:
            d["active"][k] = v
    if "waveforms" in change and change["waveforms"]:
        d["active"]["schedule"] = list(change["waveforms"])
    with pytest.raises(ConfigError) as e:
        parse_scenario(d, "s.toml")
    msg = str(e.value)
    assert words in msg and "\n" not in msg and msg.startswith("s.toml: [active")


def test_schedule_without_waveforms_is_an_error():
    d = scenario()
    d["active"] = {"waveform": "cw", "fc": 1000.0, "duration": 0.2, "level_db": 200.0,
                   "interval": 1.0, "schedule": ["cw"]}
    with pytest.raises(ConfigError, match="needs \\[active.waveforms"):
        parse_scenario(d, "s.toml")


def test_replicas_and_schedule_round_trip(tmp_path):
    scen = parse_scenario(scenario(), "s.toml")
    path = simulate(scen, tmp_path / "rec.h5")
    with Recording(path) as rec:
        act = rec.active()
    np.testing.assert_allclose(act.time, 0.2 + 1.5 * np.arange(4))
    assert act.waveform == ["hfm", "bpsk", "hfm", "bpsk"]
    assert sorted(act.waveforms) == ["bpsk", "hfm"]
    for name, w in scen.active.waveforms.items():
        r = act.waveforms[name]
        n = int(np.ceil(w.duration * FS)) + 1
        np.testing.assert_allclose(r.samples, w(np.arange(n) / FS), atol=1e-12)
        assert r.kind == w.kind and r.duration == w.duration and r.fs == FS
    assert act.waveforms["bpsk"].bits == 255 and act.waveforms["bpsk"].fc == 1500.0
    assert act.waveforms["hfm"].fc == 1500.0 and act.waveforms["hfm"].bandwidth == 400.0
    np.testing.assert_allclose(act.projector, [10.0, 0.0, 0.0])
    with h5py.File(path, "r") as f:
        assert [x.decode() for x in f["truth/pings/waveform"][()]] == act.waveform
        np.testing.assert_allclose(f["truth/pings/level_db"][()], [190, 200, 190, 200])
        np.testing.assert_allclose(f["truth/pings/time"][()], act.time)
        assert f["active/waveforms/hfm"].attrs["level_db"] == 190.0


def test_rendered_pings_follow_the_schedule():
    """The direct blast of each ping is its own waveform at its own level: the received pulse
    correlates with its replica, not the other one, and the HFM pings are 10 dB weaker."""
    d = scenario()
    d["active"]["interval"] = 1.5
    sim = Simulator(parse_scenario(d, "s.toml"))
    x = sim.render(0, sim.n_samples)[:, 0].astype(float)
    a = sim.active
    r = 10.0  # projector 10 m ahead of the single hydrophone
    rms = []
    for tp, name in zip(a.ping_times, a.ping_names):
        w = a.spec.waveforms[name]
        i0 = int(round((tp + r / C) * FS))
        seg = x[i0 + 20:i0 + int(w.duration * FS) - 20]
        rms.append(np.sqrt(np.mean(seg ** 2)))
        own = w((np.arange(seg.size) + 20 + (i0 - (tp + r / C) * FS)) / FS)
        other = a.spec.waveforms["bpsk" if name == "hfm" else "hfm"](
            (np.arange(seg.size) + 20) / FS)
        rho = abs(seg @ own) / np.linalg.norm(seg) / np.linalg.norm(own)
        rho_x = abs(seg @ other) / np.linalg.norm(seg) / np.linalg.norm(other)
        assert rho > 0.99 and rho_x < 0.1, (name, rho, rho_x)
    # spherical spreading is the same for every ping: the level difference is the source's
    ratio_db = 20 * np.log10(np.mean(rms[1::2]) / np.mean(rms[0::2]))
    assert ratio_db == pytest.approx(10.0, abs=0.1)


def test_truth_echo_levels_use_each_pings_level():
    d = scenario()
    d["active"]["direct"] = False
    d["active"]["target"] = [{"name": "t", "start": [0.0, 300.0], "heading": 0.0,
                              "ts_db": 0.0}]
    sim = Simulator(parse_scenario(copy.deepcopy(d), "s.toml"))
    lv = sim.active.windows["level_db"]
    np.testing.assert_allclose(lv[1::2] - lv[0::2], 10.0, atol=1e-9)
