#!/usr/bin/env python
"""Latency of ``arrayproc process --follow``: a recorder appends to a recording in HDF5 SWMR
mode at real time while the command follows it; this script polls the live products file and
measures, for every ``btr`` row, the time from the recorder's flush of the row's last sample
to the row's appearance on disk (the whole path: the poll, the chain, the stage's own
buffering, the products flush, the reader's poll). Then it checks the live products against
a run on the finished file (every dataset, bit for bit).

The recorder is ``arrayproc/evaluate/live_writer.py`` (8 hydrophones at 1 kHz, seeded noise and a
tone; chunks of ``--chunk`` s, a pause of the same length after each: real time). The chain:
CBF of 256-sample snapshots (batches of 2), sliding integration of 2, BTR and LOFAR.

    python scripts/bench_follow.py [--seconds 30] [--chunk 0.1] [--poll 0.02] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
from arrayproc.evaluate.compare import same_products  # noqa: E402
from arrayproc.evaluate.live_writer import wait_ready  # noqa: E402
from arrayproc.evaluate.scenarios.follow import follow_chain  # noqa: E402

WRITER = REPO / "arrayproc" / "evaluate" / "live_writer.py"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=30.0)
    ap.add_argument("--chunk", type=float, default=0.1, help="recorder chunk and pause, s")
    ap.add_argument("--poll", type=float, default=0.02, help="this reader's poll, s")
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    env = dict(os.environ, PYTHONPATH=str(REPO))
    tmp = Path(tempfile.mkdtemp(prefix="bench_follow."))
    chain, rec, live, log = follow_chain(tmp), tmp / "rec.h5", tmp / "live.h5", tmp / "writer.json"
    load0 = os.getloadavg()
    w = subprocess.Popen([sys.executable, str(WRITER), str(rec), str(log), str(a.seconds),
                          str(a.chunk), str(a.chunk), "0", str(live)], stderr=subprocess.PIPE,
                         text=True, env=env)
    assert wait_ready(w)
    f = subprocess.Popen([sys.executable, "-m", "arrayproc", "process", str(rec), "-c",
                          str(chain), "-o", str(live), "--follow", "--idle", "3"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    seen: dict[int, float] = {}
    t_row = np.zeros(0)
    while f.poll() is None:
        time.sleep(a.poll)
        try:
            with h5py.File(live, "r", libver="latest", swmr=True) as g:
                if "btr/time" in g:
                    t_row = g["btr/time"][()]
                    now = time.time()
                    for i in range(len(seen), t_row.size):
                        seen[i] = now
        except (OSError, KeyError):
            continue
    out, err = f.communicate()
    w.wait()
    written = np.asarray(json.loads(log.read_text()))   # (end sample, wall time of flush)
    with h5py.File(live, "r") as g:
        t_all = g["btr/time"][()]
    fs, nfft = 1000.0, 256
    last_sample = np.ceil(t_all * fs + nfft / 2).astype(int)     # the snapshot's last + 1
    # rows seen only at the end (after the recorder's last flush) include the --idle wait
    idx = np.searchsorted(written[:, 0], last_sample)
    ok = np.array([i in seen for i in range(t_all.size)]) & (idx < written.shape[0])
    lat = np.array([seen[i] - written[idx[i], 1] for i in np.flatnonzero(ok)])
    live_rows = lat[np.array([seen[i] <= written[-1, 1] for i in np.flatnonzero(ok)])]
    whole = tmp / "whole.h5"
    subprocess.run([sys.executable, "-m", "arrayproc", "process", str(rec), "-c", str(chain),
                    "-o", str(whole), "--no-progress", "-q"], check=True, env=env)
    n_same = same_products(live, whole)
    q = np.percentile(live_rows, [5, 50, 95]) if live_rows.size else [np.nan] * 3
    res = {"seconds": a.seconds, "chunk_s": a.chunk, "poll_s": a.poll, "rows": int(t_all.size),
           "rows_timed": int(live_rows.size), "latency_s": {"p5": q[0], "median": q[1],
                                                            "p95": q[2],
                                                            "max": float(live_rows.max())},
           "identical_datasets": n_same, "cli": out.strip().splitlines(),
           "load": [load0, os.getloadavg()]}
    print(f"{t_all.size} btr rows, {live_rows.size} timed while the recorder was writing: "
          f"latency from the last sample's flush to the row on disk: 5 % {q[0]:.3f} s, median "
          f"{q[1]:.3f} s, 95 % {q[2]:.3f} s, max {live_rows.max():.3f} s")
    print("\n".join(res["cli"]))
    print(f"live products = whole-file products: {n_same} datasets bit for bit; load "
          f"{load0[0]:.1f} -> {os.getloadavg()[0]:.1f}")
    if a.json:
        Path(a.json).write_text(json.dumps(res, indent=1, default=float))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
