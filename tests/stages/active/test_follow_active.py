"""The active chain on a recording that grows while it runs (``process --follow``): each ping
goes through as soon as its receive window is complete, the last one when the stream ends,
and the products equal those of a run on the finished file bit for bit."""

from __future__ import annotations

import numpy as np

from arrayproc.chain import build_chain, run_chain
from arrayproc.chain.follow import follow_chain
from arrayproc.evaluate.compare import same_products
from arrayproc.io import products as P
from arrayproc.io.products import ProductsWriter
from arrayproc.io.recording import Recording
from tests.stages.active.test_chain_active import CHAIN, recordings  # noqa: F401


class Growing:
    """A finished recording shown as if written while read: each ``refresh`` reveals
    ``step`` more samples."""

    def __init__(self, rec: Recording, step: int) -> None:
        self._rec, self._step, self.visible = rec, step, 0

    def __getattr__(self, name: str):
        return getattr(self._rec, name)

    @property
    def n_samples(self) -> int:
        return self.visible

    def refresh(self) -> int:
        self.visible = min(self._rec.n_samples, self.visible + self._step)
        return self.visible

    def read(self, start: int, stop: int, dtype=np.float32) -> np.ndarray:
        return self._rec.read(start, min(stop, self.visible), dtype)


def test_active_chain_follows_a_growing_recording(recordings, tmp_path, monkeypatch):  # noqa: F811
    rec_path = recordings["bpsk"]
    whole, live = tmp_path / "whole.h5", tmp_path / "live.h5"
    with Recording(rec_path) as rec, ProductsWriter(whole, source=str(rec_path)) as w:
        run_chain(rec, build_chain(CHAIN.format(extra="")), w, progress=False)
    seen = []
    orig = P.GroupWriter.append

    def spy(self, **cols):
        seen.append((self._g.name, g.visible))
        return orig(self, **cols)
    monkeypatch.setattr(P.GroupWriter, "append", spy)
    with Recording(rec_path) as rec, ProductsWriter(live, source=str(rec_path),
                                                    live=True) as w:
        g = Growing(rec, 1536)
        spec = build_chain(CHAIN.format(extra="").replace("[[stage]]", "[input]\nblock = 4096"
                                                          "\n[[stage]]", 1))
        st = follow_chain(g, spec, w, idle_s=0.2, poll_s=0.0)
        n_total = rec.n_samples
    assert st.reason.startswith("no new samples")
    assert same_products(whole, live) >= 10
    # the first ping's contacts were written while the recording was still growing
    first = [v for name, v in seen if name.endswith("cfar")]
    assert first and first[0] < n_total
