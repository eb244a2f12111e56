"""Re-validation of the passive chain in a realistic ocean (docs/validation/realism.md).

- Passive end to end (the set-up of arrayproc/evaluate/scenarios/thesis_passive.py: 32
  hydrophones, two tonal sources and one broadband source at −10 dB per hydrophone, chain
  data/chains/passive_e2e.toml) in the free field and with image-source multipath
  (pressure-release surface; surface + 200 m bottom with 6 dB loss): detection fraction and
  bearing RMS per source, the LOFAR line within one bin, and the range (max − min) of the
  multipath field level at the source's frequency over the run (Lloyd's-mirror fading; the
  broadband source at its band centre), from /truth.
- Bearings through a turn with a water-pulled array, rigid against threaded geometry
  (the set-up of arrayproc/evaluate/scenarios/realism.py).

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

from arrayproc.evaluate.scenarios import realism as rz  # noqa: E402
from arrayproc.evaluate.scenarios import thesis_passive as te  # noqa: E402

OCEANS = {
    "free field": "",
    "surface (Lloyd's mirror)": "multipath = { surface = true, order = 1 }\n",
    "surface + bottom 200 m, 6 dB, order 2": (
        "multipath = { surface = true, bottom_depth = 200.0, bottom_loss_db = 6.0, "
        "order = 2 }\n"),
}


def e2e(duration: float, multipath: str, d: Path, noise_up_db: float = 0.0,
        source_depth: float | None = None) -> dict:
    """Run the passive end-to-end set-up with the given ``[propagation]`` multipath line
    (and the noise ``noise_up_db`` louder: the sources that much below −10 dB per element)."""
    from arrayproc.chain import run_chain
    from arrayproc.io.products import ProductsWriter, read_products
    from arrayproc.io.recording import Recording
    from arrayproc.sim.run import simulate_file
    from arrayproc.stages import load_chain

    text = te.scenario(duration).replace('[propagation]\nloss = "spherical"\n',
                                         '[propagation]\nloss = "spherical"\n' + multipath)
    text = text.replace(f"[noise]\nlevel_db = {te.NL}\n",
                        f"[noise]\nlevel_db = {te.NL + noise_up_db}\n")
    if source_depth is not None:  # every source (the scenario puts them at 50 m)
        text = text.replace("depth = 50.0\n", f"depth = {source_depth}\n")
    scen = d / "scen.toml"
    scen.write_text(text)
    rec = d / "rec.h5"
    simulate_file(scen, rec)
    prod = d / "prod.h5"
    spec = load_chain(str(te.CHAIN))
    with Recording(rec) as r, ProductsWriter(prod, source=str(rec), chain=spec.text) as w:
        run_chain(r, spec, w)
    res = te.score_e2e(rec, read_products(prod))
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


TDE_CHAIN = """
[input]
block = 8192
[[stage]]
type = "tde"
reference = 3
band = [200.0, 3000.0]
weighting = "{w}"
nfft = 8192
hop = 8192
"""
COMPACT_MULTIPATH = {"surface": True, "bottom_depth": 168.0, "bottom_loss_db": 6.0,
                     "order": 1}


def plane_wave_bearing(tau: np.ndarray, el: np.ndarray, ref: int, c: float) -> np.ndarray:
    """Bearing (deg true) of the least-squares plane wave through each row's delays
    (τ_i = −(e_i − e_ref)·u / c: arrival at i after the reference)."""
    a = -(el - el[ref]) / c
    u = np.linalg.lstsq(a, tau.T, rcond=None)[0].T
    return np.degrees(np.arctan2(u[:, 0], u[:, 1])) % 360.0


def tdoa(duration: float, d: Path) -> dict:
    """The compact tetrahedral array (data/scenarios/tetrahedral_compact.toml), free field and
    with surface + seabed image sources: GCC (plain and PHAT) delays against the direct path's
    true TDOAs, and the plane-wave bearing."""
    from arrayproc.chain import build_chain, run_chain
    from arrayproc.config import read_toml
    from arrayproc.io.products import ProductsWriter, read_products
    from arrayproc.io.recording import Recording
    from arrayproc.io.truth import sources
    from arrayproc.sim.run import simulate
    from arrayproc.sim.scenario import parse_scenario

    path = ROOT / "arrayproc/data/scenarios/tetrahedral_compact.toml"
    out = {}
    for label, mp in (("free field", None), ("surface + seabed 168 m", COMPACT_MULTIPATH)):
        data, _ = read_toml(path, "scenario")
        data["recording"]["duration"] = duration
        if mp is not None:
            data["propagation"] = {"loss": "spherical", "multipath": dict(mp)}
        rec_path = d / f"tdoa_{len(out)}.h5"
        simulate(parse_scenario(data, str(path), base_dir=path.parent), rec_path)
        for w in ("none", "phat"):
            spec = build_chain(TDE_CHAIN.format(w=w))
            prod = d / f"tdoa_{len(out)}_{w}.h5"
            with Recording(rec_path) as rec, ProductsWriter(prod, source=str(rec_path),
                                                            chain=spec.text) as pw:
                run_chain(rec, spec, pw)
            g = read_products(prod)["tde"]
            with Recording(rec_path) as rec:
                c = rec.sound_speed
                el = np.asarray(rec.pose(0.0).elements, float)
                s = sources(rec)["vessel"]
                depth = float(s["attrs"]["depth"])
                t = g["time"]
                tau_t = np.zeros((t.size, el.shape[0]))
                for i, ti in enumerate(t):  # direct path at emission time, per element
                    r = np.zeros(el.shape[0])
                    for _ in range(6):
                        xs = np.array([np.interp(ti - r.mean() / c, s["time"], s["position"][:, k])
                                       for k in range(2)] + [depth])
                        r = np.linalg.norm(el - xs, axis=1)
                    tau_t[i] = (r - r[3]) / c
                brg_t = np.array([np.degrees(np.arctan2(*(
                    np.array([np.interp(ti, s["time"], s["position"][:, k]) for k in range(2)])
                    - el[:, :2].mean(0)))) % 360.0 for ti in t])
            err = g["tau"] - tau_t
            brg = plane_wave_bearing(g["tau"], el, 3, c)
            db = (brg - brg_t + 180.0) % 360.0 - 180.0
            out[f"{label}, {w}"] = {"delay_rms_us": float(np.sqrt(np.mean(err[:, :3] ** 2)) * 1e6),
                                    "delay_max_us": float(np.abs(err[:, :3]).max() * 1e6),
                                    "bearing_rms_deg": float(np.sqrt(np.mean(db ** 2))),
                                    "rows": int(t.size)}
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--e2e", type=float, default=50.0, help="seconds of the passive e2e run")
    ap.add_argument("--noise-up", type=float, default=0.0,
                    help="dB added to the noise (lower SNR)")
    ap.add_argument("--no-turn", action="store_true", help="skip the turn comparison")
    ap.add_argument("--tdoa", type=float, default=0.0,
                    help="seconds of the compact-array TDOA comparison (0: skip)")
    ap.add_argument("--no-e2e", action="store_true", help="skip the passive e2e runs")
    ap.add_argument("--source-depth", type=float, default=None,
                    help="depth of every e2e source, m (default the set-up's 50 m)")
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    from arrayproc.stages import load_all
    load_all()
    out: dict = {"e2e": {}}
    with tempfile.TemporaryDirectory() as tmp:
        for label, mp in ({} if args.no_e2e else OCEANS).items():
            d = Path(tmp) / str(len(out["e2e"]))
            d.mkdir()
            out["e2e"][label] = e2e(args.e2e, mp, d, args.noise_up, args.source_depth)
        print(f"passive end to end, {args.e2e:g} s (chain data/chains/passive_e2e.toml), "
              f"sources at {-10 - args.noise_up:g} dB per hydrophone:")
        print(f"{'ocean':<40}{'source':<11}{'detected':>9}{'RMS deg':>9}{'LOFAR ±1 bin':>13}"
              f"{'swing dB':>10}")
        for label, res in out["e2e"].items():
            for name, *_ in te.SOURCES:
                r = res[name]
                lof = r.get("lofar_within_one_bin", float("nan"))
                print(f"{label:<40}{name:<11}{r['detected']:>9.2f}{r['rms_deg']:>9.2f}"
                      f"{lof:>13.2f}{r.get('level_swing_db', 0.0):>10.1f}")
        if args.tdoa:
            out["tdoa"] = tdoa(args.tdoa, Path(tmp))
            print(f"compact tetrahedral array, {args.tdoa:g} s: GCC delays vs the direct "
                  "path's TDOAs")
            for k, r in out["tdoa"].items():
                print(f"  {k:<32} delay RMS {r['delay_rms_us']:7.2f} µs (max "
                      f"{r['delay_max_us']:7.2f}), plane-wave bearing RMS "
                      f"{r['bearing_rms_deg']:.2f}° ({r['rows']} snapshots)")
        if args.no_turn:
            return _dump(out, args.json)
        d = Path(tmp) / "turn"
        d.mkdir()
        (d / "s.toml").write_text(rz.turn_scenario())
        from arrayproc.sim.run import simulate_file
        rec = simulate_file(d / "s.toml", d / "rec.h5")
        rows = {}
        for shape in ("rigid", "threaded"):
            t, e = rz.turn_bearing_errors(rec, shape, d)
            L = 31 * 1.5
            turn = (t > rz.T_TURN + L / rz.TURN_V) & (t < 95.0)
            straight = t < rz.T_TURN - 4.0
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
    _dump(out, args.json)


def _dump(out: dict, path: str | None) -> None:
    if path:
        Path(path).write_text(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
