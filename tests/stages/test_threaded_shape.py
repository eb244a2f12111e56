"""The chain reader's ``array_shape = "threaded"``: element positions estimated from /nav by
the threading model, against the simulator's water-pulled truth shape, and the bearings of a
source through a turn with the rigid and the threaded geometry."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from arrayproc.chain import build_chain
from arrayproc.chain.reader import read_blocks
from arrayproc.errors import ConfigError
from arrayproc.evaluate.scenarios.realism import (
    T_TURN,
    turn_bearing_errors,
    turn_chain_text,
    turn_scenario,
)
from arrayproc.evaluate.scenarios.realism import TURN_RATE as RATE
from arrayproc.evaluate.scenarios.realism import TURN_V as V
from arrayproc.geo.threading import threaded_positions
from arrayproc.io.recording import Recording


@pytest.fixture(scope="module")
def recording(tmp_path_factory) -> Path:
    from arrayproc.sim.run import simulate_file
    d = tmp_path_factory.mktemp("threaded")
    (d / "s.toml").write_text(turn_scenario())
    return simulate_file(d / "s.toml", d / "rec.h5")


def test_threaded_positions_follow_the_truth_shape(recording):
    """Threading on 1 s nav fixes reproduces the simulator's water-pulled shape (exact
    arc length on the true track) to the chord error of the nav polyline."""
    with Recording(recording) as rec:
        truth = rec.read_group("truth/array")
        tt = truth["shape_time"]
        sel = (tt > 5.0) & (tt < rec.duration - 5.0)
        _, world = threaded_positions(rec.nav, rec.positions, tt[sel])
        ep = truth["element_positions"][sel]
        err = np.linalg.norm(world - ep, axis=2).max()
        rigid = np.array([rec.pose(t).elements for t in tt[sel]])
        err_rigid = np.linalg.norm(rigid - ep, axis=2).max()
        # through the reader: block positions in the body frame, pose elements in the world
        blocks = list(read_blocks(rec, 8192, array_shape="threaded"))
        b = blocks[len(blocks) // 2]
        _, w = threaded_positions(rec.nav, rec.positions, np.array([b.t0 + 0.5 * b.span]))
    r = V / math.radians(RATE)
    print(f"threaded from /nav vs truth shape: max {err * 100:.2f} cm over {sel.sum()} times "
          f"(rigid: {err_rigid:.2f} m; turn radius {r:.0f} m, nav chord sagitta "
          f"{V ** 2 / (8 * r) * 100:.2f} cm)")
    assert err < 0.05
    assert err_rigid > 2.0
    np.testing.assert_allclose(b.pose.elements, w[0], atol=1e-9)
    assert not np.allclose(b.positions[:, 1], 0.0, atol=0.5)  # bent in the body frame


def test_bearings_through_a_turn_rigid_vs_threaded(recording, tmp_path):
    t, e_rigid = turn_bearing_errors(recording, "rigid", tmp_path)
    _, e_thr = turn_bearing_errors(recording, "threaded", tmp_path)
    L = 31 * 1.5
    turn = (t > T_TURN + L / V) & (t < 95.0)  # the whole array in the turn
    straight = t < T_TURN - 4.0
    rms = lambda e: float(np.sqrt(np.mean(e ** 2)))  # noqa: E731
    print(f"bearings RMS (cone angle) in the turn: rigid {rms(e_rigid[turn]):.2f} deg, "
          f"threaded {rms(e_thr[turn]):.2f} deg ({turn.sum()} BTR rows); straight leg: rigid "
          f"{rms(e_rigid[straight]):.2f}, threaded {rms(e_thr[straight]):.2f} deg")
    assert turn.sum() >= 10
    assert rms(e_thr[turn]) < 0.5 * rms(e_rigid[turn])
    assert rms(e_thr[turn]) < 1.0
    assert abs(rms(e_thr[straight]) - rms(e_rigid[straight])) < 0.2


def test_array_shape_key_is_checked():
    with pytest.raises(ConfigError, match="array_shape"):
        build_chain(turn_chain_text("bent"))
