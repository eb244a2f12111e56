"""Hypothesis fuzzing of the configuration validators (chains, scenarios, trackers)
and of recording attributes: whatever the document, only the project's own errors
(:class:`~arrayproc.errors.ArrayprocError`) escape.

Documents are built from the real keys of each format (so the validators get past the first
check) with values of every TOML type, including non-finite floats, path-like strings and
nested tables. The default run is reduced; ``-m slow`` runs thousands of documents each.
"""

from __future__ import annotations

import json
import math
import os
import tempfile
from pathlib import Path

import h5py
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from arrayproc.app.api import build_chain
from arrayproc.app.resources import estimate_chain_bytes
from arrayproc.errors import ArrayprocError
from arrayproc.sim.scenario import parse_scenario
from arrayproc.track.runner import load_tracker_config
from tests.app.hostile_cases import SCENARIO, TRACKER

try:
    import tomllib
except ModuleNotFoundError:  # pragma: no cover
    import tomli as tomllib

FAST = settings(max_examples=150, deadline=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
SLOW = settings(max_examples=3000, deadline=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])

STAGE_TYPES = ["power", "pass", "cbf", "integrate", "btr", "lofar", "bearings", "lines",
               "dft_filter",
               "ibf", "etam", "psas", "tde", "mvdr", "music", "lr_cbf", "x", ""]
CHAIN_KEYS = ["type", "name", "input", "band", "ref", "nfft", "hop", "beams", "window",
              "snapshots", "mode", "batch", "threads", "decimate", "taper", "complex",
              "normalise", "count", "shading", "threshold_db", "lines", "loading", "wng_db",
              "sources", "smoothing", "weights", "peak_widths"]

scalars = st.one_of(
    st.integers(-10**12, 10**12), st.floats(allow_nan=True, allow_infinity=True),
    st.booleans(), st.sampled_from(["", ".", "..", "a/b", "hann", "cbf", "power", "x" * 50]),
    st.text(max_size=8))
values = st.recursive(scalars, lambda inner: st.one_of(
    st.lists(inner, max_size=4), st.dictionaries(
        st.sampled_from(["start", "stop", "count", "bearings", "elevations", "spacing", "freq",
                         "level_db", "a"]), inner, max_size=4)), max_leaves=8)


def _stage():
    return st.fixed_dictionaries({"type": st.one_of(st.sampled_from(STAGE_TYPES), values)},
                                 optional={k: values for k in CHAIN_KEYS if k != "type"})


chains = st.fixed_dictionaries({}, optional={
    "input": st.one_of(st.dictionaries(st.sampled_from(["block", "x"]), values, max_size=2),
                       values),
    "stage": st.one_of(st.lists(_stage(), max_size=4), values),
    "extra": values})


def _check_chain(doc) -> None:
    try:
        build_chain(doc)
    except ArrayprocError:
        pass
    parts = estimate_chain_bytes(doc, 8, 1000.0)  # never raises, whatever the document
    assert all(isinstance(b, float) and b >= 0 for _, b in parts)


@FAST
@given(chains)
def test_chain_validator(doc):
    _check_chain(doc)


@pytest.mark.slow
@SLOW
@given(chains)
def test_chain_validator_slow(doc):
    _check_chain(doc)


# -- scenarios: mutate a valid scenario ----------
BASE_SCENARIO = tomllib.loads(SCENARIO)


def _paths(d, prefix=()):
    for k, v in d.items():
        yield (*prefix, k)
        if isinstance(v, dict):
            yield from _paths(v, (*prefix, k))
        elif isinstance(v, list):
            for i, x in enumerate(v):
                if isinstance(x, dict):
                    yield from _paths(x, (*prefix, k, i))


SCENARIO_PATHS = list(_paths(BASE_SCENARIO))
mutations = st.lists(st.tuples(st.sampled_from(SCENARIO_PATHS), values), min_size=1, max_size=4)


def _mutated(base, muts):
    doc = json.loads(json.dumps(base))
    for path, v in muts:
        node = doc
        try:
            for k in path[:-1]:
                node = node[k]
            node[path[-1]] = v
        except (KeyError, IndexError, TypeError):
            continue
    return doc


def _check_scenario(muts) -> None:
    try:
        parse_scenario(_mutated(BASE_SCENARIO, muts), "fuzz.toml")
    except ArrayprocError:
        pass


@FAST
@given(mutations)
def test_scenario_validator(muts):
    _check_scenario(muts)


@pytest.mark.slow
@SLOW
@given(mutations)
def test_scenario_validator_slow(muts):
    _check_scenario(muts)


# -- trackers: TOML text through the loader ----------
def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf") if math.isinf(v) \
            else repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    return "{" + ", ".join(f"{json.dumps(k)} = {_toml_value(x)}" for k, x in v.items()) + "}"


TRACKER_KEYS = ["filter", "lr", "side", "model", "sigma_bearing_deg", "q1", "q2", "bearings",
                "nav", "params", "cone_gate", "level", "range_m", "sigma_range_m", "speed_mps",
                "sigma_speed_mps", "sigma_course_deg", "sigma_turn_deg_s", "mode", "other"]
trackers = st.dictionaries(st.sampled_from(TRACKER_KEYS), values, max_size=6)

_TMP = Path(tempfile.mkdtemp(prefix="arrayproc-fuzz-"))


def _check_tracker(over) -> None:
    doc = tomllib.loads(TRACKER)["tracker"]
    doc.update(over)
    text = "[tracker]\n" + "".join(f"{k} = {_toml_value(v)}\n" for k, v in doc.items())
    p = _TMP / "t.toml"
    p.write_text(text)
    try:
        tomllib.loads(text)
    except tomllib.TOMLDecodeError:
        return  # not a document our writer can express (e.g. a key repeated)
    try:
        load_tracker_config(str(p))
    except ArrayprocError:
        pass


@FAST
@given(trackers)
def test_tracker_validator(over):
    _check_tracker(over)


@pytest.mark.slow
@SLOW
@given(trackers)
def test_tracker_validator_slow(over):
    _check_tracker(over)


# -- recording attributes ----------
attr_values = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True), st.integers(-2**31, 2**31),
    st.text(st.characters(blacklist_characters="\x00"), max_size=4),  # h5py refuses NUL
    st.just(np.zeros(0)), st.lists(st.floats(-1e6, 1e6), min_size=2,
                                                        max_size=3).map(np.array))
arrays = st.one_of(
    st.just("group"), st.just(np.zeros(0)), st.just(np.array([b"a", b"b"])),
    st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=1, max_size=12).map(
        np.array),
    st.integers(1, 6).map(lambda n: np.zeros((n, 3))),
    st.integers(1, 6).map(lambda n: np.ones((n, 2))))
recordings = st.fixed_dictionaries({}, optional={
    "sample_freq": attr_values, "sound_speed": attr_values, "format_version": attr_values,
    "array/positions": arrays, "array/gains": arrays, "array/dead": arrays,
    "nav/time": arrays, "nav/position": arrays, "nav/heading": arrays, "truth": arrays})


def _check_recording(spec) -> None:
    from arrayproc.app.describe import describe
    from arrayproc.io.recording import Recording
    fd, name = tempfile.mkstemp(suffix=".h5", dir=_TMP)
    os.close(fd)
    try:
        with h5py.File(name, "w") as f:
            f.attrs["format"] = "arrayproc.recording"
            f.attrs["format_version"] = 1
            td = f.create_dataset("time_data", data=np.zeros((64, 4), np.float32))
            td.attrs["sample_freq"] = 100.0
            for k, v in spec.items():
                if k in ("sample_freq",):
                    td.attrs[k] = v
                elif k in ("sound_speed", "format_version"):
                    f.attrs[k] = v
                elif isinstance(v, str):
                    f.create_group(k)
                else:
                    f.create_dataset(k, data=v)
        for fn in (lambda: Recording(name).close(), lambda: describe(name)):
            try:
                fn()
            except ArrayprocError:
                pass
    finally:
        os.unlink(name)


@FAST
@given(recordings)
def test_recording_attributes(spec):
    _check_recording(spec)


@pytest.mark.slow
@SLOW
@given(recordings)
def test_recording_attributes_slow(spec):
    _check_recording(spec)
