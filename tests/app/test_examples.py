"""Every example shipped in data/ is valid: chains build, scenarios load, trackers load."""

from __future__ import annotations

import pytest

from arrayproc.app.api import load_chain
from arrayproc.data import data_path
from arrayproc.sim.scenario import load_scenario
from arrayproc.track.runner import load_tracker_config

DATA = data_path()


@pytest.mark.parametrize("path", sorted((DATA / "chains").glob("*.toml")), ids=lambda p: p.name)
def test_chain_examples_build(path):
    assert load_chain(str(path)).stages


@pytest.mark.parametrize("path", sorted((DATA / "scenarios").glob("*.toml")),
                         ids=lambda p: p.name)
def test_scenario_examples_load(path):
    assert load_scenario(path).duration > 0


@pytest.mark.parametrize("path", sorted((DATA / "trackers").glob("*.toml")),
                         ids=lambda p: p.name)
def test_tracker_examples_load(path):
    assert load_tracker_config(str(path))["filter"]
