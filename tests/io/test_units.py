"""The sample unit and the level labels (io/units.py): dB re 1 µPa only for pascals."""

from __future__ import annotations

import pytest

from arrayproc.io.units import file_units, level_label, reference_amplitude


@pytest.mark.parametrize("units,label", [("Pa", "dB re 1 µPa"), ("FS", "dB re FS"),
                                         ("V", "dB re 1 V")])
def test_level_label_follows_the_unit(units, label):
    assert level_label(units) == label
    assert level_label(units, "²") == label + "²"


def test_reference_amplitude_is_1_micropascal_only_for_pascals():
    assert reference_amplitude("Pa") == 1e-6
    assert reference_amplitude("FS") == 1.0
    assert reference_amplitude("FS", 0.5) == 0.5  # a given ref wins


@pytest.mark.parametrize("attrs,units", [({}, "Pa"), ({"units": b"FS"}, "FS"),
                                         ({"units": ""}, "Pa"), ({"units": "Pa"}, "Pa")])
def test_file_without_the_attribute_is_pascals(attrs, units):
    assert file_units(attrs) == units
