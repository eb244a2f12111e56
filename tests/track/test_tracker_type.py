"""``[tracker] type``: the explicit tracker type, the older implicit form meaning the same, and
every shipped tracker file naming its type."""

from __future__ import annotations

import pytest

from arrayproc.config import read_toml
from arrayproc.data import data_path
from arrayproc.errors import ConfigError
from arrayproc.track.runner import check_tracker_config
from arrayproc.track.types import TRACKER_TYPES, legacy_table, tracker_type

SHIPPED = sorted(data_path("trackers").glob("*.toml"))


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.stem)
def test_shipped_trackers_name_their_type_and_mean_what_the_old_form_meant(path):
    doc, _ = read_toml(path, "tracker")
    t = doc["tracker"]
    assert t["type"] in TRACKER_TYPES and "mode" not in t
    new = check_tracker_config(t, str(path))
    old = check_tracker_config(legacy_table(t), str(path))
    assert new.pop("type", t["type"]) == t["type"]
    old.pop("type", None)
    assert repr(new) == repr(old)


@pytest.mark.parametrize("table, kind", [
    ({}, "single"), ({"mode": "single"}, "single"), ({"mode": "multi"}, "multi"),
    ({"mode": "multi", "measurements": "contacts"}, "multi"),
    ({"mode": "multi", "measurements": "delays"}, "delays"),
    ({"type": "delays"}, "delays"), ({"type": "multi", "measurements": "positions"}, "multi"),
])
def test_type_explicit_or_implicit(table, kind):
    assert tracker_type(table) == kind


@pytest.mark.parametrize("table, msg", [
    ({"type": "mult"}, "tracker.type must be one of single, multi, delays, not 'mult'"),
    ({"type": "multi", "mode": "multi"}, "tracker.mode is the older form of tracker.type"),
    ({"type": "multi", "measurements": "delays"}, "the TDOA tracker is type = 'delays'"),
    ({"type": "delays", "measurements": "bearings"}, "tracker.measurements must be 'delays'"),
    ({"mode": "many"}, "tracker.mode must be 'single' or 'multi', not 'many'"),
])
def test_bad_type_is_one_line_naming_the_file_and_key(table, msg):
    with pytest.raises(ConfigError, match="^t.toml: ") as e:
        check_tracker_config(table, "t.toml")
    assert msg in str(e.value) and "\n" not in str(e.value)


def test_delays_tracker_by_type_keeps_its_keys():
    cfg = check_tracker_config({"type": "delays", "delays": {"motion": "cv"}}, "t.toml")
    assert cfg["type"] == "delays" and cfg["multi"] == {"measurements": "delays"}
    assert cfg["delays"]["motion"] == "cv"
