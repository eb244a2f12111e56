"""``as_text`` (HDF5 values as str) and ``resolve_beside`` (paths named inside files)."""

import os

import h5py
from hypothesis import given
from hypothesis import strategies as st

from arrayproc.config import resolve_beside
from arrayproc.io.text import as_text


@given(st.text(st.characters(blacklist_categories=("Cs",), blacklist_characters="\x00"),
               max_size=40))
def test_as_text_round_trips_through_hdf5_attributes(tmp_path_factory, s):
    p = tmp_path_factory.mktemp("t") / "a.h5"
    with h5py.File(p, "w") as f:
        f.attrs["s"] = s
        f.attrs["b"] = s.encode()
    with h5py.File(p, "r") as f:
        assert as_text(f.attrs["s"]) == s
        assert as_text(f.attrs["b"]) == s


def test_resolve_beside(tmp_path, monkeypatch):
    d = tmp_path / "sub"
    d.mkdir()
    (d / "rec.h5").write_bytes(b"")
    named_by = str(d / "prod.h5")
    monkeypatch.chdir(tmp_path)
    assert resolve_beside("rec.h5", named_by) == os.path.join(str(d), "rec.h5")
    assert resolve_beside("missing.h5", named_by) == "missing.h5"
    assert resolve_beside("", named_by) == ""
    assert resolve_beside(str(d / "rec.h5"), "/elsewhere/x.h5") == str(d / "rec.h5")
    (tmp_path / "rec.h5").write_bytes(b"")   # the working directory wins when it has it
    assert resolve_beside("rec.h5", named_by) == "rec.h5"
