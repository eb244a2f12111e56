"""Contacts of a turning platform: the port/starboard bearings use the array's heading while
the echo arrives (``/nav`` at the echo's middle, t_p + tau + T/2), not the heading at the
transmission, and the absolute Doppler's own-motion term (thesis eq. (4.9)) takes the
projector's leg at the transmission (its heading, speed and the swing of its offset in the
turn) and the array's at the reception, for either side
(:func:`arrayproc.stages.active.contacts.ownship_closing_sides`)."""

from __future__ import annotations

import numpy as np
import pytest

import arrayproc.stages.active.detect  # noqa: F401  (registers the stage types)
import arrayproc.stages.active.matched_filter  # noqa: F401
import arrayproc.stages.active.ping_beams  # noqa: F401
from arrayproc.chain import build_chain, run_chain
from arrayproc.io.products import ProductsWriter, read_products
from arrayproc.io.recording import Recording
from arrayproc.stages.active import contacts as ct

C = 1500.0
T = 1.0
ROCK = np.array([-1500.0, -60.0])  # still scatterer, about 1.5 km west: echo 2 s after the ping
TURN = 3.0  # deg/s, to port from 180 deg from t = 1 s


def scenario() -> dict:
    act = {"waveform": "bpsk", "fc": 1500.0, "bits": 255, "duration": T, "level_db": 210.0,
           "interval": 5.0, "first": 1.5, "count": 1, "offset": [20.0, 0.0, 5.0],
           "direct": False, "taper": 0.02,
           "target": [{"name": "rock", "start": ROCK.tolist(), "depth": 60.0,
                       "heading": 0.0, "ts_db": 20.0}]}
    return {"recording": {"fs": 5120.0, "duration": 5.5, "sound_speed": C, "seed": 11},
            "array": {"type": "line", "n": 32, "spacing": 0.5, "depth": 60.0},
            "ownship": {"start": [0.0, 0.0],
                        "leg": [{"course": 180.0, "speed": 3.0, "duration": 1.0},
                                {"course": 150.0, "speed": 3.0, "duration": 12.0,
                                 "turn_rate": TURN}]},
            "active": act, "noise": {"level_db": 60.0}}


CHAIN = """
[[stage]]
type = "active_beams"
beams = { start = 0.0, stop = 180.0, count = 181 }
[[stage]]
type = "matched_filter"
range_rate = { min = -4.0, max = 4.0 }
[[stage]]
type = "cfar"
pfa = 1e-6
min_range_m = 100.0
"""


@pytest.fixture(scope="module")
def turning(tmp_path_factory):
    from arrayproc.sim.run import simulate
    from arrayproc.sim.scenario import parse_scenario
    d = tmp_path_factory.mktemp("turn")
    rec = simulate(parse_scenario(scenario(), "turn.toml"), d / "turn.h5")
    out = d / "p.h5"
    with Recording(rec) as r, ProductsWriter(out, source=str(rec)) as w:
        run_chain(r, build_chain(CHAIN), w)
    g = read_products(out)
    con = next(v for k, v in g.items() if k != "/" and v["kind"] in ("contacts", b"contacts"))
    return rec, con


def _wrap(a):
    return np.mod(np.asarray(a, float) + 180.0, 360.0) - 180.0


def test_bearings_use_the_heading_at_reception(turning):
    rec_path, con = turning
    assert con["time"].size
    with Recording(rec_path) as rec:
        _, hd_rx, _, _ = rec.nav.at(con["time"] + T / 2)
        hd_tx = float(rec.pose(float(rec.active().time[0])).heading)
    np.testing.assert_allclose(_wrap(con["bearing_port_deg"] - (hd_rx - con["cone_deg"])), 0.0,
                               atol=1e-9)
    np.testing.assert_allclose(_wrap(con["bearing_stbd_deg"] - (hd_rx + con["cone_deg"])), 0.0,
                               atol=1e-9)
    # the strongest (the rock's echo, 2 s after the ping): the platform turned by about
    # TURN x 2.5 s between the transmission and the echo's middle
    assert abs(_wrap(hd_rx[np.argmax(con["snr_db"])] - hd_tx)) > 5.0


def test_rock_bearing_true_at_reception(turning):
    """The strongest contact is the rock: its starboard bearing is the true bearing from the
    array at the echo's middle within a beam step and the beamwidth's interpolation, closer
    than the bearing from the heading at the transmission, which is off by the turn."""
    rec_path, con = turning
    j = int(np.argmax(con["snr_db"]))
    with Recording(rec_path) as rec:
        t_mid = float(con["time"][j]) + T / 2
        pa, _, _, _ = rec.nav.at(t_mid)
        hd_tx = float(rec.pose(float(rec.active().time[0])).heading)
    d = ROCK - pa[0]
    true_brg = np.rad2deg(np.arctan2(d[0], d[1])) % 360.0
    err = abs(_wrap(con["bearing_stbd_deg"][j] - true_brg))
    err_tx = abs(_wrap(hd_tx + con["cone_deg"][j] - true_brg))
    assert err < 1.5
    assert err_tx > 5.0


def test_rock_is_still_in_the_turn(turning):
    """The still rock, to starboard, in a 3 deg/s turn: its starboard absolute Doppler is 0
    within the bank's interpolation (0.1 m/s); the port one and the mean are not (the
    projector 20 m ahead swings sideways at 1.05 m/s and the heading changed by 7.5 deg:
    sides apart by U sin(cone) sin(dh) + 2 omega p_x sin(cone) cos(dh), about 0.65 m/s
    here); classified still."""
    rec_path, con = turning
    j = int(np.argmax(con["snr_db"]))
    assert abs(con["absolute_doppler_stbd_mps"][j]) < 0.1
    assert con["absolute_doppler_port_mps"][j] - con["absolute_doppler_stbd_mps"][j] > 0.5
    assert con["absolute_doppler_mps"][j] == pytest.approx(
        0.5 * (con["absolute_doppler_port_mps"][j] + con["absolute_doppler_stbd_mps"][j]))
    assert not bool(con["moving"][j])
    # against the simulator's truth range rate of the echo (two legs, projector rigidly
    # offset on the turning platform): the starboard own closing removes it
    from arrayproc.io.truth import echo_truth
    with Recording(rec_path) as rec:
        tr = echo_truth(rec)
    r_true = float(tr["range_rate_mps"][0])
    cl_stbd = con["absolute_doppler_stbd_mps"][j] - con["range_rate_mps"][j]
    assert abs(r_true + cl_stbd) < 0.03


@pytest.mark.parametrize("cone", [10.0, 60.0, 95.0, 150.0])
@pytest.mark.parametrize("dh,rate", [(-8.0, -3.0), (0.0, 0.0), (6.4, 1.0)])
def test_ownship_closing_sides_closed_form(cone, dh, rate):
    """Exact two-way closing of a still scatterer at bearing b: projector leg
    (v_p . d) with v_p = U_tx x + omega z x p at heading h_tx, array leg U_rx cos(b - h_rx),
    evaluated in world coordinates (x east, y north) for b = h_rx -/+ cone; the mean is
    ``ownship_closing``; a straight leg gives U cos(cone) on both sides."""
    u_tx, u_rx, h_rx, p = 3.0, 2.6, 140.0, np.array([60.0, 4.0, 20.0])
    h_tx = h_rx - dh
    w = np.deg2rad(rate)

    def unit(h):  # compass heading -> east, north
        return np.array([np.sin(np.deg2rad(h)), np.cos(np.deg2rad(h))])

    fwd, stb = unit(h_tx), unit(h_tx + 90.0)
    # body-frame velocity of the projector on a platform turning at omega about the down axis
    v_body = np.array([u_tx - w * p[1], w * p[0]])
    v_p = v_body[0] * fwd + v_body[1] * stb
    exact = [0.5 * (v_p @ unit(b) + u_rx * np.cos(np.deg2rad(b - h_rx)))
             for b in (h_rx - cone, h_rx + cone)]
    port, stbd = ct.ownship_closing_sides(cone, u_tx, u_rx, dh, rate, p)
    assert float(port) == pytest.approx(exact[0], abs=1e-12)
    assert float(stbd) == pytest.approx(exact[1], abs=1e-12)
    assert float(ct.ownship_closing(cone, u_tx, u_rx, dh, rate, p)) == pytest.approx(
        0.5 * (exact[0] + exact[1]), abs=1e-12)
    straight = ct.ownship_closing_sides(cone, u_tx, None, 0.0, 0.0, p)
    for v in straight:
        assert float(v) == pytest.approx(u_tx * np.cos(np.deg2rad(cone)), abs=1e-12)
