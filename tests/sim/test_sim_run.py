"""Simulator runs: same seed → same bytes at any chunk size, /nav and /truth, validation of
scenario files and the command line."""

from __future__ import annotations

import copy

import h5py
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from arrayproc.app.cli import main
from arrayproc.data import data_path
from arrayproc.errors import ConfigError
from arrayproc.io.recording import Recording
from arrayproc.sim.run import Simulator, simulate, simulate_file
from arrayproc.sim.scenario import load_scenario, parse_scenario

SCENARIOS = data_path("scenarios")

EVERYTHING = {
    "recording": {"fs": 2048.0, "duration": 3.0, "seed": 4, "chunk": 1000},
    "array": {"type": "line", "n": 5, "spacing": 1.0, "depth": 30.0, "lateral_std": 0.1,
              "lateral_snapshot": 0.25, "position_error_std": 0.02},
    "ownship": {"start": [0.0, 0.0], "course": 45.0, "speed_kn": 5.0},
    "source": [{"name": "a", "start": [400.0, 300.0], "depth": 20.0, "course": 270.0,
                "speed": 4.0, "tonals": [{"freq": 150.0, "level_db": 140.0}],
                "broadband": {"band": [50.0, 600.0], "level_db": 110.0}},
               {"name": "b", "start": [-300.0, 500.0], "depth": 5.0, "course": 90.0,
                "speed": 6.0, "broadband": {"band": [80.0, 900.0], "model": "speed"}}],
    "noise": {"spectrum": [[50.0, 70.0], [800.0, 58.0]],
              "towship": {"distance": 200.0, "depth": 4.0,
                          "tonals": [{"freq": 60.0, "level_db": 150.0}]}},
    "active": {"waveform": "cw", "fc": 700.0, "duration": 0.3, "level_db": 200.0,
               "interval": 1.0, "first": 0.1, "offset": [20.0, 0.0, -5.0],
               "target": [{"source": "a", "ts_db": 10.0}],
               "clutter": {"count": 5, "area": [-500.0, 500.0, -500.0, 500.0], "depth": 80.0}},
}


def scen(d: dict | None = None, **rec):
    d = copy.deepcopy(EVERYTHING if d is None else d)
    d["recording"].update(rec)
    return parse_scenario(d, "everything.toml")


def test_same_seed_same_bytes_any_chunk(tmp_path):
    a = simulate(scen(chunk=1000), tmp_path / "a.h5")
    b = simulate(scen(chunk=4096), tmp_path / "b.h5")
    c = simulate(scen(seed=5), tmp_path / "c.h5")
    with h5py.File(a) as fa, h5py.File(b) as fb, h5py.File(c) as fc:
        xa, xb, xc = fa["time_data"][()], fb["time_data"][()], fc["time_data"][()]
        assert xa.dtype == np.float32
        assert xa.tobytes() == xb.tobytes()
        assert not np.array_equal(xa, xc)
        for k in ("truth/echoes/delay_s", "truth/sources/a/position", "nav/position"):
            assert fa[k][()].tobytes() == fb[k][()].tobytes()


@settings(max_examples=4, deadline=None)
@given(chunk=st.integers(64, 3000))
def test_render_is_chunk_independent(chunk):
    sim = Simulator(scen(duration=1.2))
    whole = sim.render(0, sim.n_samples)
    sim2 = Simulator(scen(duration=1.2))
    parts = [sim2.render(k, min(sim.n_samples, k + chunk))
             for k in range(0, sim.n_samples, chunk)]
    assert np.concatenate(parts).tobytes() == whole.tobytes()


def test_nav_and_truth_written(tmp_path):
    out = simulate(scen(), tmp_path / "r.h5")
    with Recording(out) as r:
        assert r.n_channels == 5 and r.fs == 2048.0
        assert r.nav.time[0] == 0.0 and r.nav.time[-1] == 3.0
        assert np.allclose(r.nav.heading, 45.0)
        tr = r.read_group("truth")
        for name in ("a", "b", "towship"):
            g = tr["sources"][name]
            assert g["position"].shape == (g["time"].size, 2)
            assert g["velocity"].shape == (g["time"].size, 2)
        a = tr["sources"]["a"]["attrs"]
        assert list(a["tonal_freqs"]) == [150.0] and a["depth"] == 20.0
        assert list(a["broadband_band"]) == [50.0, 600.0]
        b = tr["sources"]["b"]
        v = np.hypot(*b["velocity"][0])
        assert b["broadband_source_level_db"][0] == pytest.approx(170 + 53 * np.log10(v / 5.14))
        assert tr["ownship"]["heading"].shape == tr["ownship"]["time"].shape
        assert list(tr["pings"]["time"]) == [0.1, 1.1, 2.1]
        e = tr["echoes"]
        assert e["ping"].size == 3 * 6  # 3 pings × (1 target + 5 clutter)
        for k in ("target", "delay_s", "range_rate_mps", "level_db"):
            assert e[k].size == e["ping"].size
        assert tr["array"]["positions"].shape == (5, 3)


def test_example_scenarios_validate():
    names = sorted(p.name for p in SCENARIOS.glob("*.toml"))
    assert "towed_passive.toml" in names
    for p in SCENARIOS.glob("*.toml"):
        load_scenario(p)


@pytest.mark.parametrize("mutate, match", [
    (lambda d: d["recording"].update(fss=1.0), r"\[recording\]: unknown key 'fss'"),
    (lambda d: d["recording"].update(fs="fast"), r"\[recording\] fs: must be a number"),
    (lambda d: d["recording"].pop("duration"), r"\[recording\] duration: missing"),
    (lambda d: d["source"][0].update(tonals=[{"freq": 5000.0, "level_db": 1.0}]),
     r"\[source\[0\]\.tonals\[0\]\] freq: .* above the simulator's band"),
    (lambda d: d["source"][0]["broadband"].pop("band"), r"\[source\[0\]\.broadband\] band"),
    (lambda d: d["active"].update(waveform="lfm"), r"\[active\] waveform: must be one of"),
    (lambda d: d["active"]["target"][0].update(source="nobody"), r"no \[\[source\]\] named"),
    (lambda d: d.update(extra={}), r"top level: unknown key 'extra'"),
    (lambda d: d["array"].update(type="ring"), r"\[array\] type"),
    (lambda d: d["ownship"].update(speed_kn="x"), r"\[ownship\] speed_kn: must be a number"),
])
def test_scenario_errors_name_the_key(mutate, match):
    d = copy.deepcopy(EVERYTHING)
    mutate(d)
    with pytest.raises(ConfigError, match=match):
        parse_scenario(d, "everything.toml")


def test_cli_simulate_and_errors(tmp_path, capsys):
    out = tmp_path / "rec.h5"
    rc = main(["simulate", str(SCENARIOS / "towed_passive.toml"), "-o", str(out),
               "--duration", "2", "--seed", "7", "--no-progress"])
    assert rc == 0 and out.exists()
    with Recording(out) as r:
        assert r.duration == 2.0
        assert r._f.attrs["seed"] == 7
    bad = tmp_path / "bad.toml"
    bad.write_text('[recording]\nfs = 1000.0\nduration = 1.0\nspeed = 3\n[array]\nn = 2\n'
                   'spacing = 1.0\n')
    before = set(tmp_path.iterdir())
    rc = main(["simulate", str(bad), "-o", str(tmp_path / "x.h5")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1
    assert "bad.toml" in err[0] and "'speed'" in err[0]
    assert set(tmp_path.iterdir()) == before
    bad.write_text("[recording\n")
    assert main(["simulate", str(bad), "-o", str(tmp_path / "x.h5")]) == 2
    assert main(["simulate", str(tmp_path / "none.toml"), "-o", str(tmp_path / "x.h5")]) == 2


def test_duration_override(tmp_path):
    out = simulate_file(SCENARIOS / "towed_passive.toml", tmp_path / "s.h5", duration=1.0)
    with Recording(out) as r:
        assert r.n_samples == int(r.fs)


@pytest.mark.parametrize("mutate, match", [
    (lambda d: d["recording"].update(start_time="yesterday"), r"start_time: not an ISO-8601"),
    (lambda d: d["ownship"].update(heading=10.0), r"\[ownship\] heading: only for a static"),
    (lambda d: d["active"]["clutter"].update(area=[1.0, 0.0, 0.0, 1.0]), r"clutter\] area"),
    (lambda d: d["source"][1].update(name="a"), r"duplicate or reserved source name"),
])
def test_more_scenario_errors(mutate, match):
    d = copy.deepcopy(EVERYTHING)
    mutate(d)
    with pytest.raises(ConfigError, match=match):
        parse_scenario(d, "everything.toml")


@pytest.mark.slow
def test_long_recording_memory_is_bounded(tmp_path):
    """A 20-minute 64-channel recording (600 MiB) streams without growing the process."""
    import resource
    d = {"recording": {"fs": 2048.0, "duration": 1200.0, "seed": 1},
         "array": {"type": "line", "n": 64, "spacing": 0.36, "depth": 50.0},
         "ownship": {"start": [0.0, 0.0], "course": 0.0, "speed_kn": 5.0},
         "source": [{"name": "s", "start": [3000.0, 0.0], "depth": 20.0, "course": 180.0,
                     "speed": 3.0, "tonals": [{"freq": 300.0, "level_db": 140.0}],
                     "broadband": {"band": [50.0, 900.0], "level_db": 110.0}}],
         "noise": {"level_db": 60.0}}
    warm = copy.deepcopy(d)
    warm["recording"]["duration"] = 5.0
    simulate(parse_scenario(warm, "short.toml"), tmp_path / "warm.h5")
    (tmp_path / "warm.h5").unlink()
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    out = simulate(parse_scenario(d, "long.toml"), tmp_path / "long.h5")
    grown = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before) / 1024
    size = out.stat().st_size / 2**20
    print(f"20 min x 64 ch: file {size:.0f} MiB, peak RSS grew {grown:.0f} MiB")
    assert size > 550 and grown < 100
