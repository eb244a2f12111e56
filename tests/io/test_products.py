"""Products files: columns appended as blocks come, atomic write, segment windows."""

from __future__ import annotations

import h5py
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from arrayproc.errors import FormatError
from arrayproc.io.products import ProductsWriter, read_products


@settings(max_examples=25, deadline=None)
@given(sizes=st.lists(st.integers(0, 50), min_size=1, max_size=8), width=st.integers(1, 6))
def test_append_round_trip(tmp_path_factory, sizes, width):
    rng = np.random.default_rng(sum(sizes) + width)
    p = tmp_path_factory.mktemp("p") / "out.h5"
    parts_t, parts_g = [], []
    with ProductsWriter(p, source="rec.h5", chain="[x]") as w:
        g = w.group("btr", "btr")
        g.set("cone_deg", np.linspace(0, 180, width))
        for n in sizes:
            t = rng.random(n)
            grid = rng.random((n, width)).astype(np.float32)
            g.append(time=t, power_db=grid)
            parts_t.append(t)
            parts_g.append(grid)
    d = read_products(p)
    assert d["/"]["complete"] and d["/"]["source"] == "rec.h5"
    assert d["btr"]["kind"] == "btr" and d["btr"]["stage"] == "btr"
    assert np.array_equal(d["btr"]["time"], np.concatenate(parts_t))
    assert np.array_equal(d["btr"]["power_db"], np.concatenate(parts_g))
    assert np.allclose(d["btr"]["cone_deg"], np.linspace(0, 180, width))


def test_failed_run_leaves_nothing(tmp_path):
    p = tmp_path / "out.h5"
    with pytest.raises(RuntimeError), ProductsWriter(p) as w:
        w.group("a", "power").append(time=np.arange(3.0), power_db=np.zeros((3, 1)))
        raise RuntimeError("boom")
    assert list(tmp_path.iterdir()) == []


def test_incomplete_until_closed_and_atomic_rename(tmp_path):
    p = tmp_path / "out.h5"
    w = ProductsWriter(p)
    w.group("a", "power").append(time=np.arange(3.0), power_db=np.zeros((3, 1)))
    assert not p.exists()  # still under a temporary name
    w.close()
    with h5py.File(p) as f:
        assert bool(f.attrs["complete"]) and f["a/time"].compression == "gzip"


def test_time_window_keeps_segment_rows(tmp_path):
    p = tmp_path / "out.h5"
    with ProductsWriter(p, time_window=(1.0, 2.0)) as w:
        w.group("a", "power").append(time=np.array([0.5, 1.0, 1.5, 2.0]),
                                     power_db=np.arange(4.0)[:, None])
    d = read_products(p)["a"]
    assert list(d["time"]) == [1.0, 1.5] and list(d["power_db"][:, 0]) == [1.0, 2.0]


def test_schema_refuses_undeclared_kinds_and_columns_and_reads_check_required(tmp_path):
    p = tmp_path / "out.h5"
    with ProductsWriter(p) as w:
        with pytest.raises(FormatError, match="unknown product kind 'bearing'"):
            w.group("x", "bearing")
        with pytest.raises(FormatError, match="level_dB are not declared for kind 'power'"):
            w.group("a", "power").append(time=np.arange(2.0), level_dB=np.zeros(2))
        w.group("b", "power").append(time=np.arange(2.0))  # power_db missing
    with pytest.raises(FormatError, match="'b' .*lacks column.*power_db"):
        read_products(p)


def test_missing_directory_is_a_clear_error(tmp_path):
    with pytest.raises(FormatError, match="does not exist"):
        ProductsWriter(tmp_path / "nope" / "out.h5")


@pytest.mark.parametrize("kind", sorted(__import__("arrayproc.io.schema",
                                                   fromlist=["KINDS"]).KINDS))
def test_a_group_without_rows_is_the_empty_table_of_its_kind(tmp_path, kind):
    from arrayproc.io.schema import KINDS
    p = tmp_path / "p.h5"
    with ProductsWriter(p) as w:
        w.group("g", kind)
    g = read_products(p)["g"]
    k = KINDS[kind]
    for name in k.required():
        c = k.columns[name]
        assert g[name].shape[0] == 0 and g[name].ndim == 1 + len(c.trailing), name
        assert g[name].dtype == np.dtype(c.dtype), name
    with h5py.File(p) as f:  # on disk too, resizable like any row column (segments merge)
        assert all(f["g"][n].maxshape[0] is None for n in k.required())
