"""Bench: the multi-target GNN tracker against the same tracker assembled from Stone Soup.

20 simultaneous targets (2-D constant velocity, 3-12 km from a static observer) seen as
contacts [bearing, range, range rate] with P_D = 0.9 and Poisson clutter (``--clutter`` per
scan, uniform in bearing, range 1-15 km and range rate ±10 m/s) for ``--scans`` scans of 10 s.
Both trackers get the same rows in the same process: ours
(:func:`arrayproc.track.multi.contacts_manager`: batched EKF, χ² gate, GNN by
``linear_sum_assignment``, 3-of-5 confirmation, deletion after 5 misses) and Stone Soup's
(:func:`arrayproc.interop.stonesoup.gnn_tracker`: the same CV model, EKF, gate, 2-D
assignment, 3-point initiation, deletion after 5 misses). Only tracking is timed (building
the Stone Soup ``Detection`` objects is not). Also reported: confirmed tracks and the final
GOSPA (c = 500 m, p = 2) of each against the truth.

    .venv/bin/python scripts/bench_multi.py [--scans 1000] [--clutter 5] [--json OUT]
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import math
import time

import numpy as np

from arrayproc.evaluate.metrics import gospa
from arrayproc.interop.stonesoup import gnn_tracker, to_ss_bearing
from arrayproc.track.manage.initiate import MofN
from arrayproc.track.manage.tracks import Status
from arrayproc.track.multi import contacts_manager
from arrayproc.track.state import Context

SIG = (math.radians(1.0), 15.0, 0.2)  # bearing rad, range m, range rate m/s
Q = 0.01
DT = 10.0


def scenario(n_targets: int, n_scans: int, clutter: float, seed: int):
    """Truth (T, n, 4) [x, y, vx, vy] and per-scan measurement arrays (m, 3)."""
    rng = np.random.default_rng(seed)
    r0 = rng.uniform(3000, 12000, n_targets)
    b0 = rng.uniform(0, 2 * math.pi, n_targets)
    sp = rng.uniform(2, 8, n_targets)
    co = rng.uniform(0, 2 * math.pi, n_targets)
    x0 = np.stack([r0 * np.sin(b0), r0 * np.cos(b0), sp * np.sin(co), sp * np.cos(co)], 1)
    t = np.arange(n_scans) * DT
    truth = np.empty((n_scans, n_targets, 4))
    truth[..., :2] = x0[None, :, :2] + t[:, None, None] * x0[None, :, 2:]
    truth[..., 2:] = x0[None, :, 2:]
    scans = []
    for k in range(n_scans):
        d = truth[k, rng.random(n_targets) < 0.9]
        r = np.hypot(d[:, 0], d[:, 1])
        z = np.stack([np.arctan2(d[:, 0], d[:, 1]), r,
                      (d[:, 0] * d[:, 2] + d[:, 1] * d[:, 3]) / r], 1)
        z += rng.standard_normal(z.shape) * np.array(SIG)
        nc = rng.poisson(clutter)
        c = np.stack([rng.uniform(-math.pi, math.pi, nc), rng.uniform(1000, 15000, nc),
                      rng.uniform(-10, 10, nc)], 1)
        zz = np.vstack([z, c])
        scans.append(zz[rng.permutation(len(zz))])
    return t, truth, scans


def run_ours(t, scans, manager=contacts_manager, mofn=MofN, own=None,
             confirmed=Status.CONFIRMED):
    """Our tracker over the scans: (seconds, final confirmed positions (n, 2), confirmed
    count). The manager factory, the M-of-N rule, the ownship context and the confirmed
    status may come from another copy of the package (``scripts/ab_multi.py``)."""
    cfg = {"association": "gnn", "gate_prob": 0.999, "confirm": mofn(3, 5), "max_misses": 5,
           "pd": 0.9, "clutter_density": 1e-6,
           "contacts": {"sigma_bearing_deg": math.degrees(SIG[0]), "sigma_range_m": SIG[1],
                        "sigma_range_rate_mps": SIG[2], "q": Q, "sigma_speed_mps": 5.0,
                        "mirror": False}}
    own = Context(np.zeros(4)) if own is None else own
    mgr = manager(cfg)
    t0 = time.perf_counter()
    for tk, Z in zip(t, scans, strict=True):
        mgr.step(float(tk), Z, own)
    el = time.perf_counter() - t0
    final = [tr.x[:2] for tr in mgr.tracks if tr.status is confirmed]
    n_conf = sum(tr.confirmed_at is not None for tr in mgr.tracks)
    return el, np.array(final).reshape(-1, 2), n_conf


def run_stonesoup(t, scans):
    from stonesoup.buffered_generator import BufferedGenerator
    from stonesoup.models.measurement.nonlinear import CartesianToBearingRangeRate2D
    from stonesoup.reader.base import DetectionReader
    from stonesoup.types.detection import Detection

    mm = CartesianToBearingRangeRate2D(
        ndim_state=4, mapping=(0, 2), velocity_mapping=(1, 3),
        noise_covar=np.diag(np.square(SIG)), translation_offset=np.zeros((2, 1)),
        velocity=np.zeros((2, 1)))
    start = dt.datetime(2026, 1, 1)
    frames = []
    for tk, Z in zip(t, scans, strict=True):
        when = start + dt.timedelta(seconds=float(tk))
        frames.append((when, {Detection(np.array([[to_ss_bearing(z[0])], [z[1]], [z[2]]]),
                                        timestamp=when, measurement_model=mm) for z in Z}))

    class ListReader(DetectionReader):
        @BufferedGenerator.generator_method
        def detections_gen(self):
            yield from frames

    tracker = gnn_tracker(ListReader(), Q, gate_prob=0.999, min_points=3, max_misses=5,
                          measurement_model=mm)
    t0 = time.perf_counter()
    for _ in tracker:
        pass
    el = time.perf_counter() - t0
    final = [np.asarray(tr.state_vector, float).reshape(-1)[[0, 2]] for tr in tracker.tracks]
    return el, np.array(final).reshape(-1, 2), len(tracker.tracks)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scans", type=int, default=1000)
    ap.add_argument("--targets", type=int, default=20)
    ap.add_argument("--clutter", type=float, default=5.0)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    t, truth, scans = scenario(a.targets, a.scans, a.clutter, a.seed)
    ours, f_ours, n_ours = run_ours(t, scans)
    ss, f_ss, n_ss = run_stonesoup(t, scans)
    g_ours = gospa(truth[-1, :, :2], f_ours, 500.0, 2.0)
    g_ss = gospa(truth[-1, :, :2], f_ss, 500.0, 2.0)
    res = {"scans": a.scans, "targets": a.targets, "clutter_per_scan": a.clutter,
           "ours_s": ours, "stonesoup_s": ss, "ratio": ss / ours,
           "ours_live_confirmed_at_end": len(f_ours), "stonesoup_tracks_at_end": len(f_ss),
           "ours_gospa_final_m": g_ours.distance, "stonesoup_gospa_final_m": g_ss.distance,
           "ours_confirmed_ever": n_ours}
    print(json.dumps(res, indent=2))
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(res, fh, indent=2)


if __name__ == "__main__":
    main()
