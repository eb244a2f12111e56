"""How much of the last two thirds of a simulated run each source is held by one confirmed
track, from a multi-target ``tracks`` file and the truth of its recording
(:func:`arrayproc.evaluate.held.held_last_two_thirds`).

For each source, over the scans of the window (t ≥ t_end − ⅔·(t_end − t_start), every scan,
detected or not): its principal track is the confirmed track within ``--gate`` degrees of its
true cone angle at the most scans; "held" is the share of the window's scans at which that
track is confirmed and within the gate. A confirmed track within the gate of no source at
more than half of its confirmed points is false; "extra" counts the confirmed tracks, other
than the principal, that follow a source at more than half of their points (duplicates).

    arrayproc track PRODUCTS.h5 -c $(arrayproc data-dir)/trackers/multi_target.toml -o T.h5
    .venv/bin/python scripts/eval_line_tracks.py T.h5 [more.h5 …] [--gate 5] [--json OUT]
"""

from __future__ import annotations

import argparse
import json

from arrayproc.evaluate.held import held_last_two_thirds


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("tracks", nargs="+")
    ap.add_argument("--gate", type=float, default=5.0, help="cone-angle gate, deg")
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    out = {p: held_last_two_thirds(p, a.gate) for p in a.tracks}
    print(json.dumps(out, indent=1))
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(out, fh, indent=1)


if __name__ == "__main__":
    main()
