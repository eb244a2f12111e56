"""Run a Stone Soup GNN or JPDA tracker on our contacts and write its tracks in our format.

Reads the ``contacts`` rows of a products file through
:func:`arrayproc.interop.stonesoup.detection_reader` (``CartesianToBearingRangeRate2D`` at
the ownship pose; a line array's port and starboard bearings both as detections), runs the
tracker assembled from Stone Soup components (:func:`~arrayproc.interop.stonesoup.gnn_tracker`,
or a JPDA tracker with ``--jpda``), and writes a ``tracks`` file that ``arrayproc plot
--kind track`` and ``arrayproc export --to rep`` read.

    .venv/bin/python scripts/example_stonesoup.py PRODUCTS.h5 -o SS_TRACKS.h5 [--jpda]

Needs the optional extra: ``pip install 'arrayproc[stonesoup]'``.
"""

from __future__ import annotations

import argparse
import math

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("products")
    ap.add_argument("-o", "--output", required=True)
    ap.add_argument("--jpda", action="store_true", help="JPDA instead of GNN")
    ap.add_argument("--sigma-bearing-deg", type=float, default=2.0)
    ap.add_argument("--sigma-range-m", type=float, default=20.0)
    ap.add_argument("--sigma-range-rate-mps", type=float, default=0.3)
    ap.add_argument("--q", type=float, default=0.01, help="CV noise, m²/s³")
    a = ap.parse_args()

    from stonesoup.models.measurement.nonlinear import CartesianToBearingRangeRate2D

    from arrayproc.interop.stonesoup import _start, detection_reader, gnn_tracker, write_tracks

    reader = detection_reader(a.products, "contacts", sigma_bearing_deg=a.sigma_bearing_deg,
                              sigma_range_m=a.sigma_range_m,
                              sigma_range_rate_mps=a.sigma_range_rate_mps)
    mm = CartesianToBearingRangeRate2D(
        ndim_state=4, mapping=(0, 2), velocity_mapping=(1, 3),
        noise_covar=np.diag([math.radians(a.sigma_bearing_deg) ** 2, a.sigma_range_m ** 2,
                             a.sigma_range_rate_mps ** 2]))
    tracker = gnn_tracker(reader, a.q, measurement_model=mm)
    if a.jpda:
        from stonesoup.dataassociator.probability import JPDA
        from stonesoup.hypothesiser.probability import PDAHypothesiser
        predictor = tracker.data_associator.hypothesiser.predictor
        hyp = PDAHypothesiser(predictor, tracker.updater, clutter_spatial_density=1e-6,
                              prob_detect=0.9)
        from stonesoup.tracker.simple import MultiTargetMixtureTracker
        tracker = MultiTargetMixtureTracker(
            initiator=tracker.initiator, deleter=tracker.deleter, detector=reader,
            data_associator=JPDA(hyp), updater=tracker.updater)
    all_tracks = set()
    for _time, tracks in tracker:
        all_tracks |= tracks
    n = write_tracks(sorted(all_tracks, key=lambda t: t.states[0].timestamp), a.output,
                     source=a.products, start=_start(a.products))
    print(f"{a.output}: {len(all_tracks)} Stone Soup tracks, {n} rows")


if __name__ == "__main__":
    main()
