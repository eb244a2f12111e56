"""Track manager on simulated 2-D targets: every target one confirmed track, clutter none."""

from __future__ import annotations

import numpy as np
import pytest

from arrayproc.track.filters.stacked import StackedEKF
from arrayproc.track.manage.delete import DeletionRule
from arrayproc.track.manage.initiate import MofN
from arrayproc.track.manage.manager import TrackManager
from arrayproc.track.manage.tracks import Status
from arrayproc.track.models.motion import ConstantVelocity
from arrayproc.track.models.position import Position

from .conftest import simulate_cv


def _manager(association: str = "gnn", sigma: float = 5.0) -> TrackManager:
    filt = StackedEKF(ConstantVelocity(q1=0.05, axes=2), Position(axes=2, sigma=sigma))

    def init(Z, t, ctx, j):
        return np.r_[Z[j], 0.0, 0.0], np.diag([sigma ** 2, sigma ** 2, 100.0, 100.0])

    return TrackManager(filt, init, association=association, gate_prob=0.999,
                        confirm=MofN(3, 4), delete=DeletionRule(max_misses=3),
                        pd=0.9, clutter_density=(4 / 16e6))


@pytest.mark.parametrize("association", ["gnn", "jpda"])
def test_each_target_one_confirmed_track(association):
    truth, Zs, labels = simulate_cv(4, 60, seed=3, pd=0.9, clutter=4)
    mgr = _manager(association)
    for k, Z in enumerate(Zs):
        mgr.step(float(k), Z)
    confirmed = [tr for tr in mgr.tracks if tr.confirmed_at is not None]
    # each target held by exactly one confirmed track to the end, with small final error
    assert len(confirmed) == 4
    finals = np.array([tr.x[:2] for tr in confirmed])
    for s in range(4):
        err = np.linalg.norm(finals - truth[s, -1, :2], axis=1)
        assert err.min() < 15.0
    assert all(tr.status is Status.CONFIRMED for tr in confirmed)


def test_clutter_alone_confirms_nothing():
    rng = np.random.default_rng(5)
    mgr = _manager()
    for k in range(100):
        mgr.step(float(k), rng.uniform(-2000, 2000, (rng.poisson(4), 2)))
    assert not [tr for tr in mgr.tracks if tr.confirmed_at is not None]


def test_coasting_then_deletion():
    mgr = _manager()
    for k in range(10):
        mgr.step(float(k), np.array([[10.0 * k, 0.0]]))
    (tr,) = mgr.tracks
    assert tr.status is Status.CONFIRMED
    mgr.step(10.0, np.zeros((0, 2)))
    mgr.step(11.0, np.zeros((0, 2)))
    assert tr.status is Status.CONFIRMED and tr.misses == 2
    # coasted prediction keeps the velocity
    assert abs(tr.x[0] - 110.0) < 5.0
    mgr.step(12.0, np.zeros((0, 2)))
    assert tr.status is Status.DELETED
    h = tr.arrays()
    assert list(h["meas"][-3:]) == [-1, -1, -1]
    assert h["status"][-1] == "deleted"


def test_duplicate_tracks_are_merged():
    filt = StackedEKF(ConstantVelocity(q1=0.05, axes=2), Position(axes=2, sigma=5.0))
    mgr = TrackManager(filt, lambda Z, t, c, j: (np.r_[Z[j], 0, 0], np.diag([25, 25, 100, 100.])),
                       confirm=MofN(1, 1), delete=DeletionRule(max_misses=3, pos=(0, 1),
                                                              merge_d2=9.0, merge_scans=2))
    mgr.step(0.0, np.array([[0.0, 0.0], [0.0, 3000.0]]))
    # a second track born on the first one (a split peak), then both see one measurement
    mgr.tracks[1].x = np.array([1.0, 1.0, 0, 0])
    for k in range(1, 5):
        mgr.step(float(k), np.array([[0.0, 0.0]]))
    alive = [tr for tr in mgr.tracks if tr.alive]
    assert len(alive) == 1 and alive[0].id == 0
