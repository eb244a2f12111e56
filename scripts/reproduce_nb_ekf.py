"""Reproduce thesis figs. 3.8-3.9 (section 3.2.1.2): narrowband EKF (KAL) against the per-sample
CBF on a simulated 697 Hz tonal.

The scenario is :mod:`arrayproc.evaluate.scenarios.thesis_narrowband`. Hydrophone samples are
synthesised with numpy, not with ``arrayproc simulate``: a point
source radiating sin(2π f0 t) (unit amplitude), received at every element with its exact
emission-time delay (so the Doppler of both platforms and the wavefront curvature are in the
samples), plus white Gaussian noise at the stated hydrophone-level SNR (signal power / noise
power over the full 0-fs/2 band). 64 elements spaced 0.36 m, fs 5120 Hz, array on a straight
track (default 5 kn; the thesis text says 5 m/s, ``--speed``). Stationary target: fixed, CPA
5000 m; moving target: reciprocal course at the array's speed on a parallel track 5000 m off
(thesis fig. 3.7). The samples go through the project's ``dft_filter`` stage (complex baseband,
band 677-717 Hz, decimation 64 to 80 Hz), then through the EKF (dual and single) and the CBF
baseline of :mod:`arrayproc.stages.narrowband.cbf_baseline`.

Reports, per scenario and SNR: the ECDF of the cone error at 0.5° (thesis: -20 dB, stationary,
99 % KAL vs 80 % CBF), percentiles, errors by cone sector (broadside / end-fire), the largest
error within 5 s after each re-initialisation (single vs dual), and the received-frequency
error against the LOFAR bin width (5120/2048 = 2.5 Hz). ``--sweep`` adds fixed-cone runs from
near end-fire to broadside.

    .venv/bin/python scripts/reproduce_nb_ekf.py --json out.json --plot figdir
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from arrayproc.evaluate.scenarios.thesis_narrowband import run_case


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--duration", type=float, default=1000.0, help="s per scenario")
    ap.add_argument("--snr", type=float, nargs="+", default=[0.0, -20.0],
                    help="hydrophone SNR, dB")
    ap.add_argument("--scenarios", nargs="*", default=["stationary", "moving"],
                    help="scenarios to run (none: only the --sweep)")
    ap.add_argument("--speed", type=float, default=5.0, help="array speed, kn")
    ap.add_argument("--reinit", type=float, default=30.0, help="re-initialisation period, s")
    ap.add_argument("--sigma-cone", type=float, default=0.05, help="deg/sqrt(s)")
    ap.add_argument("--sigma-freq", type=float, default=0.01, help="Hz/sqrt(s)")
    ap.add_argument("--sweep", type=float, nargs="*", default=[],
                    help="fixed cone angles (deg) for the end-fire/broadside sweep")
    ap.add_argument("--sweep-snr", type=float, default=-20.0)
    ap.add_argument("--sweep-s", type=float, default=120.0)
    ap.add_argument("--seed", type=int, default=17)
    ap.add_argument("--json", help="write the results here")
    ap.add_argument("--plot", help="directory for the figures")
    ap.add_argument("--plot-single", action="store_true",
                    help="also draw the thesis-style single re-initialised filter")
    args = ap.parse_args(argv)
    out = {"command": " ".join(["scripts/reproduce_nb_ekf.py"] + (argv or sys.argv[1:])),
           "thesis": {"snr_-20_stationary": {"kal_frac_below_0.5deg": 0.99,
                                             "cbf_frac_below_0.5deg": 0.80}},
           "cases": [], "sweep": []}
    seeds = np.random.SeedSequence(args.seed).spawn(64)
    i = 0
    for kind in args.scenarios:
        for snr in args.snr:
            res, series = run_case(kind, snr, args, int(seeds[i].generate_state(1)[0]))
            i += 1
            out["cases"].append(res)
            k, c = res["kal_dual"], res["cbf"]
            rp = res["reinit_ripple"]
            print(f"{kind:10s} {snr:6.1f} dB: <0.5 deg KAL {k['frac_below_0.5deg']:.3f} "
                  f"(thesis-style single {res['thesis_single']['frac_below_0.5deg']:.3f}) "
                  f"CBF {c['frac_below_0.5deg']:.3f} | p99 KAL {k['p99_deg']:.3f} "
                  f"CBF {c['p99_deg']:.3f} | ripple single/dual aligned "
                  f"{rp['kal_single_max_err_5s_deg']['max']:.3f}/"
                  f"{rp['kal_dual_max_err_5s_deg']['max']:.3f}, thesis "
                  f"{rp['thesis_single_max_err_5s_deg']['max']:.3f}/"
                  f"{rp['thesis_dual_max_err_5s_deg']['max']:.3f} deg | "
                  f"max |f err| {res['frequency']['max_abs_err_hz']:.3f} Hz", flush=True)
            if args.plot:
                from arrayproc.plots.nb_tracks import draw
                Path(args.plot).mkdir(parents=True, exist_ok=True)
                t = series["time"]
                est = {"KAL": {"time": t, "cone_deg": series["kal"]["cone_deg"],
                               "freq_hz": series["fd_kal"]},
                       "CBF": {"time": t, "cone_deg": series["cbf"]["cone_deg"],
                               "freq_hz": series["cbf"]["freq_hz"]}}
                if args.plot_single:  # the thesis's figures: one filter, no alignment
                    est["KAL single"] = {"time": t, "cone_deg": series["single"]["cone_deg"]}
                draw(est, {"time": t, "cone_deg": series["truth_cone"],
                           "freq_hz": series["truth_freq"]},
                     Path(args.plot) / f"nb_ekf_{kind}_{int(snr)}dB.png",
                     title=f"{kind} target, hydrophone SNR {snr:g} dB, array "
                           f"{args.speed:g} kn (KAL: dual EKF, phase-aligned, re-init "
                           f"{args.reinit:g} s; KAL single: one filter, thesis re-init)")
    for cone in args.sweep:
        res, _ = run_case("fixed", args.sweep_snr, args, int(seeds[i].generate_state(1)[0]),
                          cone_deg=cone)
        i += 1
        res["cone_deg"] = cone
        out["sweep"].append(res)
        print(f"cone {cone:5.1f} deg {args.sweep_snr:g} dB: <0.5 deg KAL "
              f"{res['kal_dual']['frac_below_0.5deg']:.3f} (exact Doppler "
              f"{res['kal_dual_exact_doppler']['frac_below_0.5deg']:.3f}, median "
              f"{res['kal_dual_exact_doppler']['p50_deg']:.3f} vs "
              f"{res['kal_dual']['p50_deg']:.3f}) CBF "
              f"{res['cbf']['frac_below_0.5deg']:.3f} | p99 KAL "
              f"{res['kal_dual']['p99_deg']:.3f} CBF {res['cbf']['p99_deg']:.3f}", flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
