"""The end-fire crossing in a turn through both TMA paths: ``arrayproc tma PRODUCTS.h5`` (the
products' rows) and ``arrayproc tma TRACKS.h5`` (the rows of the multi-target tracker's track),
with bearings alone and with bearings + frequency, against truth.

    python scripts/validate_per_track_tma.py --seeds 5 [--json OUT]

Scenario: :func:`arrayproc.track.batch.scenarios.endfire_turn_track` (ownship 5 kn north for
300 s, a 45° turn to starboard at 1°/s, then 5 kn on 045) and
:data:`arrayproc.track.batch.scenarios.ENDFIRE_SOURCE` (3.6 km on bearing 025, 3 m/s on course
300, tonal 300 Hz), one row every 5 s (126), σ 0.5° and 0.05 Hz, written as a recording and a
products file by :func:`arrayproc.track.batch.synthetic.write_line_array_scenario` (bearings
and lines groups); the tracks by the shipped ``multi_target`` tracker on the bearings, and the
same tracks holding each point's measurement and line frequency as the lines+bearings tracker
writes them (:func:`arrayproc.track.batch.synthetic.with_measurements`); both paths with the shipped
``tracks`` TMA file (the products path with ``method = "bearings_frequency"`` for the lines).
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import warnings
from pathlib import Path

import h5py
import numpy as np

from arrayproc.app.cli import main as cli
from arrayproc.data import data_path
from arrayproc.io.products import read_products
from arrayproc.track.batch import scenarios as S
from arrayproc.track.batch.synthetic import Source, with_measurements, write_line_array_scenario

TRUTH = np.append(S.ENDFIRE_SOURCE, 300.0)


def _run(args: list[str]) -> None:
    rc = cli([str(a) for a in args] + ["-q"])
    if rc != 0:
        raise SystemExit(f"{' '.join(map(str, args))}: exit {rc}")


def _preferred(path: Path) -> dict:
    g = read_products(str(path))["tma"]
    i = int(np.flatnonzero(g["preferred"] == 1)[0])
    st = np.array([g["x"][i], g["y"][i], g["vx"][i], g["vy"][i]])
    e = st - TRUTH[:4] - np.r_[float(g["t0"][i]) * TRUTH[2:4], 0, 0]
    f0 = float(g["f0_hz"][i]) if "f0_hz" in g else float("nan")
    return {"state": st.tolist(), "f0_hz": f0 if np.isfinite(f0) else None,
            "nees4": float(e @ np.linalg.solve(g["crlb"][i], e)),
            "range_sigma_m": float(g["range_sigma_m"][i]), "n_rows": int(g["n_used"][i])
            if "n_used" in g else None, "t0": float(g["t0"][i])}


def trial(seed: int, folder: Path) -> dict:
    folder.mkdir(parents=True, exist_ok=True)
    nav, _ = S.endfire_turn_track(n=626, dt=1.0)
    _, prod, rows = write_line_array_scenario(
        str(folder), nav, {"a": Source(S.ENDFIRE_SOURCE, 300.0)}, np.arange(0.0, 626.0, 5.0),
        0.5, 0.05, seed=seed, lines=True)
    tracks = folder / "tracks.h5"
    _run(["track", prod, "-c", "multi_target", "-o", tracks])
    tracks_f = folder / "tracks_f.h5"
    with_measurements(tracks, tracks_f, prod, rows["freq_hz"])
    cfg = Path(data_path("tma")) / "tracks.toml"
    bf_cfg = folder / "bf.toml"
    bf_cfg.write_text(cfg.read_text().replace('method = "auto"',
                                              'method = "bearings_frequency"'))
    out = {}
    for name, src, c in (("products_bearings", prod, cfg), ("track_bearings", tracks, cfg),
                         ("products_bf", prod, bf_cfg), ("track_bf", tracks_f, cfg)):
        _run(["tma", src, "-c", c, "-o", folder / f"{name}.h5"])
        out[name] = _preferred(folder / f"{name}.h5")
    with h5py.File(tracks) as f:
        used = f["tracks/row"][()]
    out["track_rows"] = int(np.unique(used[used >= 0]).size)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--json")
    a = ap.parse_args()
    warnings.simplefilter("ignore")
    res = []
    with tempfile.TemporaryDirectory() as d:
        for s in range(a.seeds):
            res.append(trial(s, Path(d) / str(s)))
    diff = {k: float(max(np.max(np.abs(np.subtract(r[f"products_{k}"]["state"],
                                                   r[f"track_{kk}"]["state"])))
                         for r in res))
            for k, kk in (("bearings", "bearings"), ("bf", "bf"))}
    s = {"seeds": a.seeds, "max_abs_state_difference_products_vs_track": diff,
         "track_rows": [r["track_rows"] for r in res],
         "mean_nees4": {k: float(np.mean([r[k]["nees4"] for r in res])) for k in res[0]
                        if k != "track_rows"},
         "trials": res}
    print(json.dumps(s, indent=1))
    if a.json:
        os.makedirs(os.path.dirname(os.path.abspath(a.json)), exist_ok=True)
        with open(a.json, "w") as fh:
            json.dump(s, fh, indent=1)


if __name__ == "__main__":
    main()
