"""The passive target picture end to end on five scenarios (``simulate → process → track →
tma`` with the shipped files), scored per source against the truth
(:mod:`arrayproc.evaluate.target_picture`; docs/validation/target_picture.md).

    .venv/bin/python scripts/validate_target_picture.py --out /tmp/tp --jobs 2 \\
        --json docs/results/target_picture.json --table
"""

from __future__ import annotations

import argparse
import json
import os

from arrayproc.evaluate.scenarios.target_picture import SCENARIOS
from arrayproc.evaluate.target_picture import evaluate, markdown_table, summary


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True, help="folder for the recordings and products")
    ap.add_argument("--jobs", type=int, default=1, help="scenarios run at once")
    ap.add_argument("--json", default=None, help="write the scores here")
    ap.add_argument("--table", action="store_true", help="print the markdown table")
    ap.add_argument("--scenario", action="append", choices=sorted(SCENARIOS),
                    help="run only these (repeatable; default all)")
    ap.add_argument("--duration", type=float, default=None, help="shorten each run, s")
    ap.add_argument("--seeds", type=int, default=1,
                    help="noise draws per scenario (seed offsets 0, 100, ...; default 1)")
    a = ap.parse_args()
    names = a.scenario or list(SCENARIOS)
    res = evaluate(names, os.path.abspath(a.out), jobs=a.jobs, duration=a.duration,
                   seeds=a.seeds)
    out = {"scenarios": res, "summary": summary(res)}
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(out, fh, indent=1)
            fh.write("\n")
    if a.table:
        print(markdown_table(res))
    print(json.dumps(out["summary"]))


if __name__ == "__main__":
    main()
