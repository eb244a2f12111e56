"""Two targets seen as contacts: our GNN tracker and the one assembled from Stone Soup
components (:func:`arrayproc.interop.stonesoup.gnn_tracker`, fed by our DetectionReader)
hold the same two tracks and agree on the final states."""

from __future__ import annotations

import math

import numpy as np
import pytest

from arrayproc.io.products import ProductsWriter
from arrayproc.io.recording import RecordingWriter
from arrayproc.track.manage.initiate import MofN
from arrayproc.track.manage.tracks import Status
from arrayproc.track.multi import contact_scans, contacts_manager

pytest.importorskip("stonesoup")

SIG = (1.0, 15.0, 0.2)


def _files(tmp_path, seed=4):
    rng = np.random.default_rng(seed)
    rec = tmp_path / "rec.h5"
    with RecordingWriter(rec, 100.0, 1, start_time="2026-01-01T00:00:00Z") as w:
        w.append(np.zeros((100, 1), np.float32))
        w.set_nav(np.array([0.0, 1000.0]), np.array([[0.0, 0.0], [0.0, 0.0]]),
                  np.array([0.0, 0.0]))
    x0 = np.array([[4000.0, 3000.0, -4.0, 1.0], [-2000.0, 6000.0, 3.0, -3.0]])
    t = np.arange(40) * 10.0
    rows = {k: [] for k in ("time", "range_m", "cone_deg", "bearing_port_deg",
                            "bearing_stbd_deg", "range_rate_mps", "ping",
                            "absolute_doppler_mps", "snr_db", "moving")}
    truth = x0[:, None, :2] + t[None, :, None] * x0[:, None, 2:]
    for k, tk in enumerate(t):
        for s in range(2):
            d = truth[s, k]
            v = x0[s, 2:]
            r = float(np.hypot(*d))
            b = math.degrees(math.atan2(d[0], d[1])) + SIG[0] * rng.standard_normal()
            rows["time"].append(tk)
            rows["range_m"].append(r + SIG[1] * rng.standard_normal())
            rows["cone_deg"].append(b % 360)
            rows["bearing_port_deg"].append(b % 360)
            rows["bearing_stbd_deg"].append(b % 360)
            rows["range_rate_mps"].append(float(d @ v) / r + SIG[2] * rng.standard_normal())
            rows["ping"].append(k)
            rows["absolute_doppler_mps"].append(rows["range_rate_mps"][-1])
            rows["snr_db"].append(20.0)
            rows["moving"].append(True)
    prod = tmp_path / "prod.h5"
    with ProductsWriter(prod, source=str(rec)) as w:
        w.group("contacts", "contacts").append(
            **{k: np.array(v) for k, v in rows.items()},
            waveform=np.array([b"cw"] * len(rows["time"])))
    return str(rec), str(prod), truth[:, -1]


def test_two_targets_agree_with_stonesoup(tmp_path):
    from stonesoup.models.measurement.nonlinear import CartesianToBearingRangeRate2D

    from arrayproc.interop.stonesoup import (
        detection_reader,
        gnn_tracker,
        tracks_to_rows,
        write_tracks,
    )
    from arrayproc.io.products import read_products
    from arrayproc.io.recording import Recording

    rec, prod, final_truth = _files(tmp_path)
    cfg = {"association": "gnn", "gate_prob": 0.999, "confirm": MofN(3, 5), "max_misses": 5,
           "pd": 0.9, "clutter_density": 1e-6,
           "contacts": {"sigma_bearing_deg": SIG[0], "sigma_range_m": SIG[1],
                        "sigma_range_rate_mps": SIG[2], "q": 0.01, "sigma_speed_mps": 5.0,
                        "mirror": True}}
    c = read_products(prod)["contacts"]
    with Recording(rec, require_geometry=False) as r:
        nav = r.nav
    mgr = contacts_manager(cfg)
    cols = {k: np.asarray(c[k], float) for k in ("time", "range_m", "bearing_port_deg",
                                                 "bearing_stbd_deg", "range_rate_mps")}
    for t, Z, _rows, own in contact_scans(cols, nav, True):
        mgr.step(t, Z, own)
    ours = sorted((tr for tr in mgr.tracks if tr.status is Status.CONFIRMED),
                  key=lambda tr: tr.x[0])
    assert len(ours) == 2

    reader = detection_reader(prod, sigma_bearing_deg=SIG[0], sigma_range_m=SIG[1],
                              sigma_range_rate_mps=SIG[2])
    mm = CartesianToBearingRangeRate2D(ndim_state=4, mapping=(0, 2), velocity_mapping=(1, 3),
                                       noise_covar=np.diag([math.radians(SIG[0]) ** 2,
                                                            SIG[1] ** 2, SIG[2] ** 2]))
    tracker = gnn_tracker(reader, 0.01, measurement_model=mm)
    for _ in tracker:
        pass
    theirs = sorted(tracker.tracks, key=lambda tr: float(tr.state_vector[0, 0]))
    assert len(theirs) == 2
    for a, b, tr in zip(ours, theirs, final_truth[np.argsort(final_truth[:, 0])], strict=True):
        xb = np.asarray(b.state_vector, float).reshape(-1)[[0, 2, 1, 3]]
        # same filter on the same detections: states within a small fraction of their σ
        sig = np.sqrt(np.diag(a.P))
        assert np.all(np.abs(a.x - xb) < 0.2 * sig + 1e-6)
        assert np.linalg.norm(a.x[:2] - tr) < 3 * math.sqrt(a.P[0, 0] + a.P[1, 1])
    # converter back to our tracks kind
    rows = tracks_to_rows(theirs)
    assert set(np.unique(rows["track_id"])) == {0, 1}
    assert rows["cov"].shape[1:] == (4, 4)
    out = tmp_path / "ss_tracks.h5"
    assert write_tracks(theirs, str(out)) == rows["time"].size
    assert read_products(str(out))["tracks"]["kind"] == "tracks"
