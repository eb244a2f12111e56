"""The stage index (arrayproc.stages.TYPES) matches what the stage modules register, and every
stage module under arrayproc/stages is in it."""

from __future__ import annotations

import importlib
import pkgutil

import arrayproc.stages as stages
from arrayproc.chain import STAGES


def test_index_matches_registrations():
    stages.load_all()
    assert {k: v.__module__ for k, v in STAGES.items() if not k.startswith("_")} == stages.TYPES


def test_every_stage_module_is_indexed():
    indexed = set(stages.TYPES.values())
    for m in pkgutil.walk_packages(stages.__path__, prefix="arrayproc.stages."):
        if m.ispkg or m.name.rsplit(".", 1)[-1].startswith("_"):
            continue
        mod = importlib.import_module(m.name)
        registers = any(getattr(v, "kind", None) in STAGES and STAGES[v.kind] is v
                        for v in vars(mod).values() if isinstance(v, type))
        assert not registers or m.name in indexed, m.name
