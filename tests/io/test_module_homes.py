"""The modules split out of io/recording.py and app/commands.py keep the old import paths:
each name imported from the old module is the object of its new home."""

from __future__ import annotations

import importlib

import pytest

MOVED = [
    ("arrayproc.io.recording", "arrayproc.io.h5",
     ["open_h5", "get_object", "read_numeric", "attr_number", "attr_str", "_attr_str"]),
    ("arrayproc.io.recording", "arrayproc.io.pings", ["Replica", "ActivePings", "read_active"]),
    ("arrayproc.io.recording", "arrayproc.io.recording_writer",
     ["RecordingWriter", "FORMAT", "FORMAT_VERSION", "DEFAULT_SOUND_SPEED"]),
    ("arrayproc.app.commands", "arrayproc.app.describe", ["info"]),
    ("arrayproc.app.commands", "arrayproc.app.process", ["process"]),
    ("arrayproc.app.commands", "arrayproc.app.recordings",
     ["import_wavs", "simulate", "start_time_from_names"]),
    ("arrayproc.app.commands", "arrayproc.app.plotting", ["plot", "default_plot_kind"]),
    ("arrayproc.app.commands", "arrayproc.app.inputs",
     ["check_plot_input", "check_product_input", "PLOT_INPUTS", "TRACK_INPUT"]),
    ("arrayproc.app.commands", "arrayproc.app.tracking", ["track", "tma"]),
    ("arrayproc.app.commands", "arrayproc.app.export", ["export"]),
    ("arrayproc.app.commands", "arrayproc.app.options", ["geometry", "add_geometry_options"]),
]


@pytest.mark.parametrize("old, new, names", MOVED, ids=[f"{o}<-{n}" for o, n, _ in MOVED])
def test_old_path_is_the_new_object(old, new, names):
    o, n = importlib.import_module(old), importlib.import_module(new)
    assert [x for x in names if getattr(o, x) is not getattr(n, x)] == []


def test_unknown_name_of_commands_is_an_attribute_error():
    from arrayproc.app import commands
    with pytest.raises(AttributeError):
        commands.no_such_command  # noqa: B018
