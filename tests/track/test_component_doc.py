"""Tracking components' signatures and docstrings come from their declared parameters."""

import inspect

from arrayproc.track.filters import FILTERS
from arrayproc.track.models.level_bearing import LevelBearing


def test_signature_and_parameters_section_list_every_declared_key():
    for cls in (*FILTERS.values(), LevelBearing):
        declared = cls.all_params()
        if not declared:
            continue
        sig = inspect.signature(cls)
        assert list(sig.parameters) == list(declared), cls
        doc = inspect.getdoc(cls)
        for k, p in declared.items():
            assert any(ln.startswith(f"{k} : {p.type_text.replace(chr(92) + '|', '|')}")
                       for ln in doc.splitlines()), (cls, k)
    assert inspect.signature(LevelBearing).parameters["sigma_deg"].default == 1.5
