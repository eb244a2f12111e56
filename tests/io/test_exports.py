"""Raven selection tables and Debrief REP: golden lines, parse-back and round trips."""

from __future__ import annotations

import datetime as dt
import math

import h5py
import numpy as np
import pytest

from arrayproc.errors import FormatError
from arrayproc.io.exports import (
    RAVEN_COLUMNS,
    latlon_to_xy,
    read_raven,
    read_rep,
    write_raven,
    write_rep,
    xy_to_latlon,
)
from arrayproc.io.products import ProductsWriter
from arrayproc.io.recording import RecordingWriter


def _recording(path, seconds: float, fs: float = 100.0, start="2026-01-01T00:00:00Z"):
    with RecordingWriter(path, fs, 2, start_time=start) as w:
        w.append(np.zeros((int(seconds * fs), 2), np.float32))
        w.set_nav(np.array([0.0, seconds]), np.array([[0.0, 0.0], [10.0 * seconds, 0.0]]),
                  np.array([90.0, 90.0]))
    return str(path)


def _detections(path, rec, t0, t1, lo, hi, ch):
    with ProductsWriter(path, source=rec) as w:
        g = w.group("transients", "detections")
        g.append(time_start=np.asarray(t0, float), time_end=np.asarray(t1, float),
                 freq_lo=np.asarray(lo, float), freq_hi=np.asarray(hi, float),
                 snr_db=np.full(len(t0), 12.5), channel=np.asarray(ch, np.int64))
    return str(path)


def test_raven_golden_and_cumulative_times(tmp_path):
    r1 = _recording(tmp_path / "a.h5", 60.0)
    r2 = _recording(tmp_path / "b.h5", 30.0)
    p1 = _detections(tmp_path / "pa.h5", r1, [10.0, 2.0], [11.5, 2.5], [100, 200], [300, 400],
                     [0, 1])
    p2 = _detections(tmp_path / "pb.h5", r2, [5.0], [6.0], [50], [60], [1])
    out = tmp_path / "sel.txt"
    assert write_raven([p1, p2], str(out)) == 3
    lines = out.read_text().splitlines()
    assert lines[0].split("\t")[:9] == list(RAVEN_COLUMNS)
    # golden first row: earliest selection, channel 2 (1-based), file-local offset
    assert lines[1].split("\t")[:9] == ["1", "Spectrogram 1", "2", "2.000000", "2.500000",
                                        "200.000000", "400.000000", "a.h5", "2.000000"]
    rows = read_raven(str(out))
    assert [r["Selection"] for r in rows] == ["1", "2", "3"]
    # the second file's selection is offset by the first file's 60 s
    assert float(rows[2]["Begin Time (s)"]) == pytest.approx(65.0)
    assert float(rows[2]["File Offset (s)"]) == pytest.approx(5.0)
    assert rows[2]["Begin File"] == "b.h5"
    assert float(rows[1]["snr_db"]) == pytest.approx(12.5)
    assert all(float(r["End Time (s)"]) > float(r["Begin Time (s)"]) for r in rows)


def test_raven_bearings_and_errors(tmp_path):
    rec = _recording(tmp_path / "a.h5", 20.0)
    p = tmp_path / "b.h5"
    with ProductsWriter(p, source=rec) as w:
        g = w.group("bearings", "bearings")
        g.append(time=np.array([1.0, 1.0, 3.0]), cone_deg=np.array([30.0, 90.0, 31.0]),
                 bearing_port_deg=np.array([60.0, 0.0, 59.0]),
                 bearing_stbd_deg=np.array([120.0, 180.0, 121.0]),
                 freq_lo=np.full(3, 60.0), freq_hi=np.full(3, 900.0), snr_db=np.ones(3),
                 level_db=np.full(3, 80.0), spl_db=np.full(3, 90.0))
    out = tmp_path / "b.txt"
    assert write_raven([str(p)], str(out)) == 3
    rows = read_raven(str(out))
    assert float(rows[0]["Begin Time (s)"]) == pytest.approx(0.0)  # 1 s − half the 2 s scan
    assert float(rows[2]["End Time (s)"]) == pytest.approx(4.0)
    assert rows[0]["cone_deg"] != ""
    empty = tmp_path / "e.h5"
    with ProductsWriter(empty, source=rec) as w:
        w.group("btr", "btr").append(time=np.zeros(1), power_db=np.zeros((1, 3)))
    with pytest.raises(FormatError, match="no detections or bearings"):
        write_raven([str(empty)], str(tmp_path / "x.txt"))
    bad = tmp_path / "bad.txt"
    bad.write_text("a\tb\n1\t2\n")
    with pytest.raises(FormatError):
        read_raven(str(bad))


def test_latlon_inverse():
    x = np.array([0.0, 1000.0, -2500.0])
    y = np.array([0.0, -400.0, 3000.0])
    lat, lon = xy_to_latlon(x, y, (50.0, -4.0))
    xb, yb = latlon_to_xy(lat, lon, (50.0, -4.0))
    np.testing.assert_allclose(xb, x, atol=1e-6)
    np.testing.assert_allclose(yb, y, atol=1e-6)
    # one minute of latitude is 1852 m on this sphere to 0.1 %
    lat1, _ = xy_to_latlon(np.zeros(1), np.array([1852.0]), (0.0, 0.0))
    assert lat1[0] * 60 == pytest.approx(1.0, rel=1e-3)


def test_rep_tracks_round_trip(tmp_path):
    rec = _recording(tmp_path / "a.h5", 100.0)
    trk = tmp_path / "t.h5"
    t = np.arange(0.0, 100.0, 10.0)
    with ProductsWriter(trk, source="p.h5", attrs={"recording": rec}) as w:
        g = w.group("tracks", "tracks")
        for tid, (x0, y0, vx, vy) in enumerate([(1000.0, 2000.0, 3.0, -1.0),
                                                (-500.0, -3000.0, 0.0, 4.0)]):
            g.append(time=t, track_id=np.full(t.size, tid), x=x0 + vx * t, y=y0 + vy * t,
                     vx=np.full(t.size, vx), vy=np.full(t.size, vy),
                     cov=np.tile(np.eye(4), (t.size, 1, 1)),
                     status=np.ones(t.size, np.int8),
                     own_x=10.0 * t, own_y=np.zeros(t.size))
    out = tmp_path / "t.rep"
    write_rep(str(trk), str(out), origin=(50.0, -4.0))
    first = out.read_text().splitlines()[1]
    assert first == "260101 000000.000 OWNSHIP @A 50 00 00.00 N 004 00 00.00 W 90.0 19.44 0.0"
    back = read_rep(str(out), origin=(50.0, -4.0))
    assert set(back.tracks) == {"OWNSHIP", "TRACK_0", "TRACK_1"}
    a = back.tracks["TRACK_0"]
    np.testing.assert_allclose(a["time"], t)
    # 0.01″ of latitude/longitude: < 0.31 m
    np.testing.assert_allclose(a["x"], 1000.0 + 3.0 * t, atol=0.35)
    np.testing.assert_allclose(a["y"], 2000.0 - 1.0 * t, atol=0.35)
    np.testing.assert_allclose(a["course"], math.degrees(math.atan2(3, -1)) % 360, atol=0.06)
    np.testing.assert_allclose(a["speed"], math.hypot(3, 1), atol=0.01)
    np.testing.assert_allclose(back.tracks["OWNSHIP"]["x"], 10.0 * t, atol=0.35)


def test_rep_sensor2_round_trip(tmp_path):
    rec = _recording(tmp_path / "a.h5", 20.0)
    p = tmp_path / "b.h5"
    port = np.array([350.5, 45.0])
    stbd = np.array([190.0, 135.0])
    with ProductsWriter(p, source=rec) as w:
        w.group("bearings", "bearings").append(
            time=np.array([2.0, 4.0]), cone_deg=np.array([100.0, 45.0]),
            bearing_port_deg=port, bearing_stbd_deg=stbd, freq_lo=np.array([148.0, 60.0]),
            freq_hi=np.array([149.0, 900.0]), level_db=np.zeros(2), snr_db=np.zeros(2),
            spl_db=np.zeros(2))
    out = tmp_path / "b.rep"
    write_rep(str(p), str(out))
    lines = [s for s in out.read_text().splitlines() if s.startswith(";SENSOR2:")]
    assert lines[0] == (";SENSOR2: 260101 000002.000 OWNSHIP @B NULL 190.0 350.5 148.5 NULL "
                        "TowedArray B0")
    back = read_rep(str(out))
    np.testing.assert_allclose(back.sensor["bearing"], stbd)
    np.testing.assert_allclose(back.sensor["ambiguous"], port)
    np.testing.assert_allclose(back.sensor["freq"], [148.5, 480.0])
    # REP times are absolute: the reader counts from the first line (2 s into the recording)
    assert back.start == dt.datetime(2026, 1, 1, 0, 0, 2, tzinfo=dt.timezone.utc)
    np.testing.assert_allclose(back.sensor["time"], [0.0, 2.0])
    assert set(back.tracks) == {"OWNSHIP"}
    bad = tmp_path / "bad.rep"
    bad.write_text("260101 000002.000 X @A 50 00\n")
    with pytest.raises(FormatError, match="bad.rep:1"):
        read_rep(str(bad))


def test_recording_helper_has_start(tmp_path):
    rec = _recording(tmp_path / "a.h5", 1.0)
    with h5py.File(rec) as f:
        assert f.attrs["start_time"]
