"""M-of-N confirmation and deletion rules."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from arrayproc.errors import ConfigError
from arrayproc.track.manage.delete import DeletionRule
from arrayproc.track.manage.initiate import MofN
from arrayproc.track.manage.tracks import Status, Track


def _track() -> Track:
    return Track(0, np.zeros(2), np.eye(2), 0.0)


@given(st.integers(1, 6), st.integers(0, 4), st.lists(st.booleans(), min_size=1, max_size=12))
def test_m_of_n_decides_as_soon_as_known(m, extra, hits):
    rule = MofN(m, m + extra)
    tr = _track()
    decided_at = None
    for k, h in enumerate(hits):
        tr.hits.append(h)
        s = rule.apply(tr)
        if s is not Status.TENTATIVE and decided_at is None:
            decided_at = k
            break
    first = hits[:rule.n]
    if decided_at is None:
        # undecided: neither m hits yet nor impossible
        assert sum(hits[:rule.n]) < m and sum(hits) + (rule.n - len(hits)) >= m
        return
    seen = first[:decided_at + 1]
    if tr.status is Status.CONFIRMED:
        assert sum(seen) == m and sum(seen[:-1]) < m
    else:
        assert sum(seen) + rule.n - len(seen) < m


def test_m_of_n_rejects_bad_values():
    with pytest.raises(ConfigError):
        MofN(4, 3)
    with pytest.raises(ConfigError):
        MofN(0, 3)


def test_deletion_after_misses_and_sigma():
    rule = DeletionRule(max_misses=3, max_sigma=100.0, pos=(0,))
    tr = _track()
    tr.status = Status.CONFIRMED
    tr.misses = 2
    assert not rule.should_delete(tr, 10.0, 8.0)
    tr.misses = 3
    assert rule.should_delete(tr, 10.0, 8.0)
    tr.misses = 0
    tr.P = np.diag([101.0 ** 2, 1.0])
    assert rule.should_delete(tr, 10.0, 10.0)
    tr.P = np.eye(2)
    assert not DeletionRule(max_misses=3, max_coast_s=5.0).should_delete(tr, 10.0, 6.0)
    assert DeletionRule(max_misses=3, max_coast_s=5.0).should_delete(tr, 12.0, 6.0)
    with pytest.raises(ConfigError):
        DeletionRule(max_misses=0)
