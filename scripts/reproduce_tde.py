"""Reproduce the thesis's time-delay figures and the TDOA localisation checks.

* fig. 3.15: Monte Carlo standard deviation of the cross-correlation delay (eqs. (3.26),
  (3.27) with FFT interpolation) for white signals of bandwidth W = 10, 100, 1000 Hz, fs 5120 Hz,
  T = 1 s, against Quazi's bounds (3.28) / (3.29) (and the CRLB whose asymptotes they are);
  the collapse SNR of each bandwidth.
* fig. 3.16: the phase-unwrapping LLS estimator (3.30)-(3.36), app. B, against the
  cross-correlation at W = 100 Hz.
* GCC-PHAT against plain cross-correlation when a copy of the source arrives −6 dB, 5 ms late.
* a compact volumetric array localising an impulsive broadband source 1-20 m away: position
  RMSE over Monte Carlo events against the CRLB from the TDOA Fisher information, and NEES.

The thesis does not give the centre frequency of its bands; ``--fc`` (default 1000 Hz) sets it,
the band being [fc − W/2, fc + W/2]. By default each trial's snapshot holds one period of a
periodic signal and the correlation is circular, so both channels hold the same signal samples
(the model of the bounds); ``--linear`` runs the signal on and correlates the finite windows
linearly, where the samples entering and leaving the window differ between the channels
(self-noise that sets a floor at high SNR). SNR is the ratio of signal to noise power spectral
densities in the band (noise white over 0-fs/2), the SNR of the bounds.

    python scripts/reproduce_tde.py --json docs/results/tde.json --plot docs/figures
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from arrayproc.evaluate.scenarios.thesis_delay import (
    FS,
    N,
    delay_mc,
    localisation_mc,
    phat_echo,
)


# -- plots -----------------------------------------------------------------------------------
def plot(res: dict, outdir: Path) -> list[str]:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    outdir.mkdir(parents=True, exist_ok=True)
    files = []
    fig, axes = plt.subplots(1, len(res["fig315"]), figsize=(15, 4.5), sharey=True)
    for ax, r in zip(np.atleast_1d(axes), res["fig315"]):
        s = np.array(r["snr_db"])
        ax.semilogy(s, r["xcorr"]["rmse_s"], "o-", label="cross-correlation (MC)")
        ax.semilogy(s, r["quazi_low_s"], "--", label="Quazi low SNR (3.28)")
        ax.semilogy(s, r["quazi_high_s"], ":", label="Quazi high SNR (3.29)")
        ax.semilogy(s, r["crlb_s"], "k-", lw=0.8, label="CRLB")
        if r["xcorr"]["collapse_snr_db"] is not None:
            ax.axvline(r["xcorr"]["collapse_snr_db"], color="r", lw=0.8, label="collapse")
        ax.set_title(f"W = {r['width_hz']:g} Hz, band {r['band_hz'][0]:g}-{r['band_hz'][1]:g}")
        ax.set_xlabel("SNR (dB)")
        ax.grid(True, which="both", alpha=0.3)
        ax.set_ylim(1e-9, 1)
    np.atleast_1d(axes)[0].set_ylabel("delay RMS error (s)")
    np.atleast_1d(axes)[0].legend(fontsize=8)
    fig.suptitle("thesis fig. 3.15: cross-correlation delay estimation, fs 5120 Hz, T = 1 s")
    fig.tight_layout()
    p = outdir / "tde_fig315.png"
    fig.savefig(p, dpi=110)
    plt.close(fig)
    files.append(str(p))
    r = res["fig316"]
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    s = np.array(r["snr_db"])
    ax.semilogy(s, r["xcorr"]["rmse_s"], "o-", label="cross-correlation")
    ax.semilogy(s, r["unwrap"]["rmse_s"], "s-", label="phase unwrapping LLS")
    ax.semilogy(s, r["crlb_s"], "k-", lw=0.8, label="CRLB (3.28)/(3.29)")
    ax.set_xlabel("SNR (dB)")
    ax.set_ylabel("delay RMS error (s)")
    ax.set_title(f"thesis fig. 3.16: W = {r['width_hz']:g} Hz")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    p = outdir / "tde_fig316.png"
    fig.savefig(p, dpi=110)
    plt.close(fig)
    files.append(str(p))
    return files


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=1000, help="trials per SNR point (fig 3.15/16)")
    ap.add_argument("--loc-runs", type=int, default=500, help="localisation Monte Carlo events")
    ap.add_argument("--phat-runs", type=int, default=200)
    ap.add_argument("--fc", type=float, default=1000.0, help="band centre, Hz")
    ap.add_argument("--snr", type=float, nargs=3, default=(-20.0, 70.0, 5.0),
                    metavar=("LO", "HI", "STEP"), help="SNR sweep, dB")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--linear", action="store_true",
                    help="figs 3.15/3.16 with running signals and linear (zero-padded) "
                         "correlation of the finite windows instead of one signal period")
    ap.add_argument("--only", choices=("fig315", "fig316", "phat", "loc"), nargs="*")
    ap.add_argument("--json", help="write the results here")
    ap.add_argument("--from-json", help="only redraw the figures of an earlier --json file")
    ap.add_argument("--plot", help="directory for the figures")
    a = ap.parse_args(argv)
    if a.from_json:
        old = json.loads(Path(a.from_json).read_text())
        print("\n".join(plot(old, Path(a.plot or "."))))
        return 0
    snrs = np.arange(a.snr[0], a.snr[1] + 1e-9, a.snr[2])
    want = set(a.only or ("fig315", "fig316", "phat", "loc"))
    res: dict = {"fs_hz": FS, "T_s": N / FS, "fc_hz": a.fc, "runs": a.runs, "seed": a.seed}
    t0 = time.perf_counter()
    if "fig315" in want:
        res["fig315"] = [delay_mc(a.runs, snrs, w, a.fc, a.seed + i, circular=not a.linear)
                         for i, w in enumerate((10.0, 100.0, 1000.0))]
        for r in res["fig315"]:
            x = r["xcorr"]
            print(f"fig3.15 W={r['width_hz']:g} Hz: collapse at {x['collapse_snr_db']} dB, "
                  f"RMSE/CRLB above it {x['min_ratio_above_collapse']}-"
                  f"{x['max_ratio_above_collapse']}", file=sys.stderr)
    if "fig316" in want:
        res["fig316"] = delay_mc(a.runs, snrs, 100.0, a.fc, a.seed + 10, ("xcorr", "unwrap"),
                                 circular=not a.linear)
    if "phat" in want:
        res["phat_echo"] = phat_echo(a.phat_runs, a.seed + 20)
    if "loc" in want:
        res["localisation"] = localisation_mc(a.loc_runs, a.seed + 30)
    res["elapsed_s"] = time.perf_counter() - t0
    if a.plot and "fig315" in res and "fig316" in res:
        res["figures"] = plot(res, Path(a.plot))
    text = json.dumps(res, indent=1)
    if a.json:
        Path(a.json).parent.mkdir(parents=True, exist_ok=True)
        Path(a.json).write_text(text)
    else:
        print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
