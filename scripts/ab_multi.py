"""Paired A/B of the multi-target contacts tracker: this checkout against the package at
another git revision, in one process.

The scenario and the tracker configuration are :mod:`bench_multi`'s (20 targets seen as
[bearing, range, range rate] contacts with clutter). The package at ``--base`` is extracted
under another name (:func:`ab_cbf.extract_base`); each package builds its own
``contacts_manager`` and the two run the same scans in alternating order, ``--pairs``
pairs. Checked first: both end with the same confirmed tracks (positions equal to 1e-9 m).
Printed: min and median seconds of each, and the median and quartiles of the paired ratio
(this checkout / base).

    .venv/bin/python scripts/ab_multi.py --base 9811696 [--pairs 12] [--scans 300]
"""

from __future__ import annotations

import importlib
import tempfile
from pathlib import Path

import numpy as np
from ab_cbf import ab_parser, alternate, extract_base
from bench_multi import run_ours, scenario


def runner(pkg: str, t, scans):
    """:func:`bench_multi.run_ours` with the contacts manager, the M-of-N rule and the
    ownship argument of package ``pkg``: a typed ``Context`` or, where a revision's manager
    takes it so (a TypeError on the first scans), the ownship state array."""
    multi = importlib.import_module(f"{pkg}.track.multi")
    mofn = importlib.import_module(f"{pkg}.track.manage.initiate").MofN
    status = importlib.import_module(f"{pkg}.track.manage.tracks").Status
    kw = dict(manager=multi.contacts_manager, mofn=mofn, confirmed=status.CONFIRMED)
    try:
        own = importlib.import_module(f"{pkg}.track.state").Context(np.zeros(4))
        run_ours(t[:5], scans[:5], own=own, **kw)
    except (ModuleNotFoundError, AttributeError, TypeError):
        own = np.zeros(4)

    def run(t, scans):
        return run_ours(t, scans, own=own, **kw)
    return run


def main() -> None:
    ap = ab_parser(__doc__)
    ap.add_argument("--scans", type=int, default=300)
    ap.add_argument("--clutter", type=float, default=5.0)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    t, _truth, scans = scenario(20, args.scans, args.clutter, args.seed)
    root = Path(__file__).resolve().parents[1]
    with tempfile.TemporaryDirectory() as tmp:
        runs = {"base": runner(extract_base(args.base, root, Path(tmp)), t, scans),
                "new": runner("arrayproc", t, scans)}
        finals = {k: run(t, scans)[1] for k, run in runs.items()}  # warm-up and check
        same = (finals["base"].shape == finals["new"].shape
                and np.allclose(finals["base"], finals["new"], rtol=0, atol=1e-9))
        print(f"same confirmed tracks at the end: {same} ({len(finals['new'])} tracks)")
        alternate({k: (lambda k=k: runs[k](t, scans)[0]) for k in runs}, args.pairs,
                  "s per run", f"{args.scans} scans")


if __name__ == "__main__":
    main()
