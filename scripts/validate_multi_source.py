"""Validation of several sources' delays at once (docs/validation/compact.md, "Several
sources at once").

1. Monte Carlo (:func:`arrayproc.evaluate.multi_source.two_source_mc`): two simultaneous
   broadband transients on the 1.84 m tetrahedron and on the six-hydrophone frame, ``--runs``
   seeds each: both found, position RMSE against the CRLB, delay RMSE against the bound.
2. End to end through the shipped files, as separate commands:

       arrayproc simulate arrayproc/data/scenarios/two_sources_compact.toml -o rec.h5
       arrayproc process rec.h5 -c arrayproc/data/chains/multi_source_snapshots.toml -o del.h5
       arrayproc track del.h5 -c arrayproc/data/trackers/tdoa_sources.toml -o trk.h5

   scored against the recording's truth (:mod:`arrayproc.evaluate.multi_source_e2e`).
3. The real six-hydrophone recording (``--xav``, the directory of xav-large-array):

       arrayproc import …/AMAR173.*.wav --geometry …/hydrophones_config_07-HI.csv \\
           --sound-speed 1484 -o xav.h5
       arrayproc process xav.h5 -c arrayproc/data/chains/multi_source_localise.toml -o xm.h5

   the events with more than one source, and a plot of the positions.

    python scripts/validate_multi_source.py --out /tmp/ms [--runs 50] \
        [--xav ../shared/data/xav-large-array]

Writes ``summary.json``, ``sim_sources.png`` and ``xav_sources.png`` in ``--out``.
"""

from __future__ import annotations

import argparse
import glob
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "arrayproc" / "data"


def _cli(*args: str) -> None:
    cmd = [sys.executable, "-m", "arrayproc", *args]
    print("$ arrayproc " + " ".join(args), file=sys.stderr)
    subprocess.run(cmd, check=True, cwd=ROOT)


def _elements(rec: str) -> np.ndarray:
    from arrayproc.io.recording import Recording

    with Recording(rec) as r:
        return np.asarray(r.pose(0.0).elements, float)


def main() -> None:
    from arrayproc.evaluate.multi_source import CASES, two_source_mc
    from arrayproc.evaluate.multi_source_e2e import (
        multi_source_events,
        plot_sources,
        score_positions,
        score_tracks,
        truth_tracks,
    )

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("--runs", type=int, default=50)
    ap.add_argument("--seed", type=int, default=100)
    ap.add_argument("--xav", default=None, help="directory of xav-large-array")
    a = ap.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    summary: dict = {"monte_carlo": {}}
    for name, make in CASES.items():
        r = two_source_mc(make(), a.runs, a.seed)
        summary["monte_carlo"][name] = r
        for s in ("source0", "source1"):
            q = r[s]
            print(f"{name:12s} {s}: found {q['found']}/{a.runs}, RMSE "
                  f"{q.get('rmse_m', float('nan')):.4f} m, CRLB {q.get('crlb_rms_m', 0):.4f} m "
                  f"(ratio {q.get('ratio_rmse_to_crlb', float('nan')):.2f}, to the bound with "
                  f"the other as noise {q.get('ratio_rmse_to_crlb_interference') or np.nan:.2f}"
                  f"; alone "
                  f"{q['alone'].get('ratio_rmse_to_crlb', float('nan')):.2f}), delays RMS "
                  f"{q.get('delay_rmse_s', np.nan) * 1e6:.1f} us (median |e| "
                  f"{q.get('delay_median_abs_s', np.nan) * 1e6:.1f} us, "
                  f"{q.get('delay_gross_errors', 0)} gross, {q.get('delays_left_out', 0)} "
                  f"left out) vs bound "
                  f"{q.get('delay_crlb_rms_s', np.nan) * 1e6:.2f} us "
                  f"(other as noise {q.get('delay_crlb_interference_rms_s', np.nan) * 1e6:.1f})")
    rec, dl, tk = (str(out / n) for n in ("rec.h5", "del.h5", "trk.h5"))
    _cli("simulate", str(DATA / "scenarios" / "two_sources_compact.toml"), "-o", rec)
    _cli("process", rec, "-c", str(DATA / "chains" / "multi_source_snapshots.toml"), "-o", dl)
    _cli("track", dl, "-c", str(DATA / "trackers" / "tdoa_sources.toml"), "-o", tk)
    summary["end_to_end"] = {"positions": score_positions(rec, dl),
                             "tracks": score_tracks(rec, tk),
                             "snapshots": {k: v for k, v in multi_source_events(dl).items()
                                           if k != "rows"}}
    plot_sources(dl, str(out / "sim_sources.png"), _elements(rec), truth_tracks(rec),
                 "two_sources_compact.toml through multi_source_snapshots.toml: localised "
                 "sources and truth")
    print(json.dumps(summary["end_to_end"], indent=1))
    if a.xav:
        wavs = sorted(glob.glob(str(Path(a.xav) / "AMAR173.*.wav")))
        xr, xm = str(out / "xav.h5"), str(out / "xav_multi.h5")
        _cli("import", *wavs, "--geometry", str(Path(a.xav) / "hydrophones_config_07-HI.csv"),
             "--sound-speed", "1484", "-o", xr)
        _cli("process", xr, "-c", str(DATA / "chains" / "multi_source_localise.toml"), "-o", xm)
        ev = multi_source_events(xm)
        summary["xav"] = ev
        plot_sources(xm, str(out / "xav_sources.png"), _elements(xr), None,
                     "xav-large-array through multi_source_localise.toml: "
                     f"{ev['with_several_sources']} of {ev['events']} events with several "
                     "sources")
        print(json.dumps(ev, indent=1))
    (out / "summary.json").write_text(json.dumps(summary, indent=1))


if __name__ == "__main__":
    main()
