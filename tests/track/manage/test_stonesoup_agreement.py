"""Two targets seen as contacts: our GNN tracker and the one assembled from Stone Soup
components (:func:`arrayproc.interop.stonesoup.gnn_tracker`, fed by our DetectionReader)
hold the same two tracks and agree on the final states."""

from __future__ import annotations

import math

import numpy as np
import pytest

from arrayproc.track.manage.initiate import MofN
from arrayproc.track.manage.tracks import Status
from arrayproc.track.multi import contact_scans, contacts_manager
from arrayproc.track.state import Context

pytest.importorskip("stonesoup")

from .conftest import SIG
from .conftest import contact_files as _files


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
    cols["ping"] = np.asarray(c["ping"], np.int64)   # one scan per ping, as `arrayproc track`
    for t, Z, _rows, own in contact_scans(cols, nav, True):
        mgr.step(t, Z, Context(own))
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
