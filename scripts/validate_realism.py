"""Re-validation of the passive chain in a realistic ocean (docs/validation/realism.md).

- Passive end to end (the set-up of tests/stages/test_passive_e2e.py: 32 hydrophones, two
  tonal sources and one broadband source at −10 dB per hydrophone, chain
  data/chains/passive_e2e.toml) in the free field and with image-source multipath
  (pressure-release surface; surface + 200 m bottom with 6 dB loss): detection fraction and
  bearing RMS per source, the LOFAR line within one bin, and the range (max − min) of the
  multipath field level at the source's frequency over the run (Lloyd's-mirror fading; the
  broadband source at its band centre), from /truth.
- Bearings through a turn with a water-pulled array, rigid against threaded geometry
  (the set-up of tests/stages/test_threaded_shape.py).

    .venv/bin/python scripts/validate_realism.py [--e2e 50] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.stages import test_passive_e2e as te  # noqa: E402
from tests.stages import test_threaded_shape as tt  # noqa: E402

OCEANS = {
    "free field": "",
    "surface (Lloyd's mirror)": "multipath = { surface = true, order = 1 }\n",
    "surface + bottom 200 m, 6 dB, order 2": (
        "multipath = { surface = true, bottom_depth = 200.0, bottom_loss_db = 6.0, "
        "order = 2 }\n"),
}


def e2e(duration: float, multipath: str, d: Path) -> dict:
    """Run the passive end-to-end set-up with the given ``[propagation]`` multipath line."""
    from arrayproc.chain import load_chain, run_chain
    from arrayproc.io.products import ProductsWriter, read_products
    from arrayproc.io.recording import Recording
    from arrayproc.sim.run import simulate_file

    text = te.scenario(duration).replace('[propagation]\nloss = "spherical"\n',
                                         '[propagation]\nloss = "spherical"\n' + multipath)
    scen = d / "scen.toml"
    scen.write_text(text)
    rec = d / "rec.h5"
    simulate_file(scen, rec)
    prod = d / "prod.h5"
    spec = load_chain(str(te.CHAIN))
    with Recording(rec) as r, ProductsWriter(prod, source=str(rec), chain=spec.text) as w:
        run_chain(r, spec, w)
    res = te.evaluate(rec, read_products(prod))
    with Recording(rec) as r:  # received tonal level swing at the reference point
        src = r.read_group("truth/sources")
        for name, *_, tonal in te.SOURCES:
            s = src[name]
            f = tonal if tonal is not None else 550.0  # the broadband band's centre
            if "path_amplitude" in s:
                amp = np.abs(np.sum(s["path_amplitude"] * np.exp(
                    -2j * np.pi * f * s["path_delay_s"]), axis=1))
                lv = 20 * np.log10(amp)
                res[name]["level_swing_db"] = float(lv.max() - lv.min())
    return res


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--e2e", type=float, default=50.0, help="seconds of the passive e2e run")
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    out: dict = {"e2e": {}}
    with tempfile.TemporaryDirectory() as tmp:
        for label, mp in OCEANS.items():
            d = Path(tmp) / str(len(out["e2e"]))
            d.mkdir()
            out["e2e"][label] = e2e(args.e2e, mp, d)
        print(f"passive end to end, {args.e2e:g} s (chain data/chains/passive_e2e.toml):")
        print(f"{'ocean':<40}{'source':<11}{'detected':>9}{'RMS deg':>9}{'LOFAR ±1 bin':>13}"
              f"{'swing dB':>10}")
        for label, res in out["e2e"].items():
            for name, *_ in te.SOURCES:
                r = res[name]
                lof = r.get("lofar_within_one_bin", float("nan"))
                print(f"{label:<40}{name:<11}{r['detected']:>9.2f}{r['rms_deg']:>9.2f}"
                      f"{lof:>13.2f}{r.get('level_swing_db', 0.0):>10.1f}")
        d = Path(tmp) / "turn"
        d.mkdir()
        (d / "s.toml").write_text(tt.scenario())
        from arrayproc.sim.run import simulate_file
        rec = simulate_file(d / "s.toml", d / "rec.h5")
        rows = {}
        for shape in ("rigid", "threaded"):
            t, e = tt.bearing_errors(rec, shape, d)
            L = 31 * 1.5
            turn = (t > tt.T_TURN + L / tt.V) & (t < 95.0)
            straight = t < tt.T_TURN - 4.0
            rows[shape] = {"turn_rms_deg": float(np.sqrt(np.mean(e[turn] ** 2))),
                           "turn_bias_deg": float(np.mean(e[turn])),
                           "straight_rms_deg": float(np.sqrt(np.mean(e[straight] ** 2))),
                           "n_turn": int(turn.sum())}
        out["turn"] = rows
        print("bearings (cone angle) through a 1.5 deg/s turn, water-pulled array:")
        for shape, r in rows.items():
            print(f"  {shape:<9} turn RMS {r['turn_rms_deg']:.2f} deg (bias "
                  f"{r['turn_bias_deg']:+.2f}, {r['n_turn']} rows), straight leg RMS "
                  f"{r['straight_rms_deg']:.2f} deg")
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
