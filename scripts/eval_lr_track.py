"""A tracked target's mirror with port/starboard-resolving beams: the bundled triplet scenario
(``data/scenarios/triplet_lr.toml``: straight leg, no manoeuvre, one broadband target to
starboard) through ``lr_cbf`` (``data/chains/lr_cbf.toml``) and through plain ``cbf`` (cone
beams, the left-right pair), each followed by the multi-target tracker
(``data/trackers/multi_target.toml``). Printed: per chain the number of tracks, the median
distance of the track's position from the target and from the target's mirror image across
the ownship track over the last 60 s, and the last estimate.

    PYTHONPATH=. .venv/bin/python scripts/eval_lr_track.py --out OUT [--json OUT/lr_track.json]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from arrayproc.data import data_path  # noqa: E402
from arrayproc.io.products import read_products  # noqa: E402

CBF_CHAIN = """[[stage]]
type = "cbf"
nfft = 1024
band = [800.0, 1200.0]
[[stage]]
type = "integrate"
snapshots = 16
[[stage]]
type = "btr"
[[stage]]
type = "bearings"
max_peaks = 1
"""
# the scenario's target: start (2500, 1500) m, course 200°, 6 kn; ownship north along x = 0
START, COURSE, SPEED = (2500.0, 1500.0), 200.0, 6 * 0.514444


def cli(*args: str) -> None:
    subprocess.run([sys.executable, "-m", "arrayproc", *args], check=True)


def evaluate(tracks: Path) -> dict:
    t = read_products(tracks)["tracks"]
    tt = t["time"]
    crs = np.deg2rad(COURSE)
    tx = START[0] + SPEED * np.sin(crs) * tt
    ty = START[1] + SPEED * np.cos(crs) * tt
    mx = 2 * t["own_x"] - tx  # mirror across the ownship track (heading north)
    sel = tt > tt[-1] - 60.0
    return {"tracks": int(np.unique(t["track_id"]).size), "rows": int(tt.size),
            "median_to_target_m_last60s": float(np.median(np.hypot(t["x"] - tx,
                                                                   t["y"] - ty)[sel])),
            "median_to_mirror_m_last60s": float(np.median(np.hypot(t["x"] - mx,
                                                                   t["y"] - ty)[sel])),
            "last_estimate": [float(t["x"][-1]), float(t["y"][-1])],
            "last_truth": [float(tx[-1]), float(ty[-1])],
            "side_weight_last": float(t["side_weight"][-1])}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("--json")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rec = out / "triplet_lr.h5"
    cli("simulate", str(data_path("scenarios", "triplet_lr.toml")), "-o", str(rec))
    (out / "cbf.toml").write_text(CBF_CHAIN)
    res = {}
    for name, chain in (("lr_cbf", str(data_path("chains", "lr_cbf.toml"))),
                        ("cbf", str(out / "cbf.toml"))):
        prod, trk = out / f"p_{name}.h5", out / f"t_{name}.h5"
        cli("process", str(rec), "-c", chain, "-o", str(prod))
        cli("track", str(prod), "-c", str(data_path("trackers", "multi_target.toml")), "-o",
            str(trk), "--no-progress")
        res[name] = evaluate(trk)
    text = json.dumps(res, indent=1)
    print(text)
    if args.json:
        Path(args.json).write_text(text)


if __name__ == "__main__":
    main()
