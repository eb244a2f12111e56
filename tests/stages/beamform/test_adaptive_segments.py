"""Segmented runs (``arrayproc batch``) of chains with ``mvdr``, ``music`` and ``lr_cbf``
equal the single run bit for bit: covariance groups lie on the absolute snapshot grid, are
multiplied out whole, and the segment reads start on the groups' grid (``segment_grid``)."""

from __future__ import annotations

import pytest

from arrayproc.app import batch
from tests.app.test_batch import assert_same, client, make_recording, single_run  # noqa: F401

CHAIN = """
[input]
block = 3000
[[stage]]
name = "raw"
type = "pass"
[[stage]]
type = "mvdr"
nfft = 256
hop = 128
band = [150.0, 850.0]
beams = { start = 0.0, stop = 180.0, count = 31 }
snapshots = 12
[[stage]]
type = "btr"
[[stage]]
type = "bearings"
min_separation = 0.0
peak_widths = 1.0
[[stage]]
name = "mu"
type = "music"
input = "raw"
nfft = 256
hop = 128
band = [150.0, 850.0]
beams = { start = 0.0, stop = 180.0, count = 31 }
snapshots = 16
sources = 1
root = true
[[stage]]
name = "mu_btr"
type = "btr"
input = "mu"
"""


@pytest.mark.parametrize("text", [CHAIN], ids=["mvdr+music"])
def test_four_segments_equal_the_single_run(tmp_path, client, text):  # noqa: F811
    rec = make_recording(tmp_path / "long.h5", 24.0, 7)
    chain = tmp_path / "c.toml"
    chain.write_text(text)
    ref = single_run(rec, chain.read_text(), tmp_path / "ref.h5")
    res = batch.run_batch([rec], chain, tmp_path / "seg", client, segment_s=6.0)
    assert res[0].status == "done" and res[0].segments == 4
    assert_same(ref, tmp_path / "seg" / "long.h5")
