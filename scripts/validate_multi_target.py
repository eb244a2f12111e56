"""Closing numbers of the multi-target tracker for tracks files of simulated
scenarios: per source the share of its detected scans held by its principal confirmed track,
breaks, final position error; false confirmed tracks; GOSPA (c = 1000 m, p = 2, α = 2) and
OSPA over time (:func:`arrayproc.evaluate.metrics.evaluate_tracks_file`).

    arrayproc simulate data/scenarios/towed_passive.toml -o rec.h5
    arrayproc process rec.h5 -c data/chains/towed_passive.toml -o prod.h5
    arrayproc track prod.h5 -c data/trackers/multi_target.toml -o tracks.h5
    .venv/bin/python scripts/validate_multi_target.py tracks.h5 [more.h5 …] [--json OUT]
"""

from __future__ import annotations

import argparse
import json

from arrayproc.evaluate.metrics import evaluate_tracks_file


def summary(path: str, c: float = 1000.0) -> dict:
    """The closing numbers of one tracks file."""
    r = evaluate_tracks_file(path, c=c)
    last_min = r["times"] >= r["times"][-1] - 60.0
    return {"sources": r["sources"], "held": [round(float(v), 3) for v in r["held"]],
            "n_detected": [int(v) for v in r["n_detected"]],
            "breaks": [int(v) for v in r["breaks"]],
            "principal": [int(v) for v in r["principal"]],
            "final_error_m": [round(float(v)) for v in r["final_error_m"]],
            "false_tracks": [int(v) for v in r["false_tracks"]],
            "n_confirmed": int(r["n_confirmed"]),
            "gospa_mean_m": round(float(r["gospa"].mean())),
            "gospa_last_minute_mean_m": round(float(r["gospa"][last_min].mean())),
            "gospa_last_m": round(float(r["gospa"][-1])),
            "ospa_mean_m": round(float(r["ospa"].mean()))}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("tracks", nargs="+")
    ap.add_argument("--cutoff", type=float, default=1000.0, help="GOSPA/OSPA cut-off, m")
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    out = {p: summary(p, a.cutoff) for p in a.tracks}
    print(json.dumps(out, indent=1))
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(out, fh, indent=1)


if __name__ == "__main__":
    main()
