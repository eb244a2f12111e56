"""Reproduce thesis chapter 2 (passive synthetic aperture, ETAM, inverse beamforming) on
simulator recordings: table 2.1b, figs. 2.8, 2.11 and 2.12, and the two-source case of
2.2.3.2-2.2.3.3.

Array: 64 hydrophones, 0.36 m apart (the thesis's CAPTAS array), towed north; a 250 Hz tonal
from a distant source (plane wave) at broadside unless said otherwise; c = 1500 m/s, 1024 Hz.

    python scripts/reproduce_psas.py [--json OUT] [--plot DIR] [--quick]

The scenarios are :mod:`arrayproc.evaluate.scenarios.thesis_synthetic_aperture`.

Gains are of the synthetic aperture over the physical aperture (one snapshot's CBF), at the
target's beam and bin:

- ideal: SNR gain from a signal-only and a noise-only recording, abutting snapshots
  (T_B = N_H δx / U, eq. 2.32), N_B = 2…10; 3 dB beamwidth ratio; modified false-alarm
  probabilities (eqs. 2.44-2.45) against Monte Carlo over the processed noise cells.
- perturbed: lateral array motion, Gaussian with σ (in wavelengths) constant within each
  snapshot (thesis 2.2.2), half-overlapping snapshots (T_B = (N_H − 1) δx / (2U), eq. 2.52),
  N_B = 10, noise-free: the mean synthetic-beam power over N_B times the physical one.
- two_sources: the target tonal at cone 100° and a broadband interferer on the same course
  2 km astern (aft end-fire) whose in-bin level at the hydrophones is 20 dB above the
  target's; lateral motion σ = 0.1 λ. Gain = excess of the target cell over the background of
  neighbouring bins, synthetic over physical, each processed the same way (raw, or after IBF).
- ibf: a static array, a broadband wave 30 dB above the noise at its beam (cone 61.3°) and one
  10 dB weaker at 81.3°; beam powers after IBF against a recording without the strong wave.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np

from arrayproc.evaluate.scenarios.thesis_synthetic_aperture import (
    ibf_alone,
    ideal,
    perturbed,
    two_sources,
)


def plots(res: dict, extra: dict, outdir: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    outdir.mkdir(parents=True, exist_ok=True)
    ideal_r, pert = res["ideal"], res["perturbed"]
    # Table 2.1b / fig 2.7: gains and widths
    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    ax[0].plot(ideal_r["n_b"], ideal_r["theory_db"], "k-", label="10 log10 N_B (table 2.1b)")
    ax[0].plot(ideal_r["n_b"], ideal_r["gain_db"], "o", label="PSAS, simulated")
    ax[0].set(xlabel="snapshots N_B", ylabel="SNR gain over physical aperture (dB)")
    ax[0].legend()
    ax[0].grid(alpha=0.3)
    ax[1].plot(ideal_r["n_b"], ideal_r["n_b"], "k-", label="N_B")
    ax[1].plot(ideal_r["n_b"], ideal_r["beamwidth_ratio"], "o", label="simulated")
    ax[1].set(xlabel="snapshots N_B", ylabel="beamwidth ratio physical / synthetic")
    ax[1].legend()
    ax[1].grid(alpha=0.3)
    fig.suptitle("Ideal passive synthetic aperture, 64 × 0.36 m, 250 Hz at broadside")
    fig.tight_layout()
    fig.savefig(outdir / "psas_ideal_gain.png", dpi=120)
    plt.close(fig)
    # fig 2.8
    pfa = ideal_r["pfa"]
    fig, ax = plt.subplots(figsize=(6, 4.5))
    for n_b, col in zip(pfa["n_b"], ("C0", "C1", "C2")):
        ax.semilogy(pfa["snr_db"], pfa[f"inco_{n_b}"]["theory"], "-", color=col,
                    label=f"incoherent N_B={n_b} (2.44)")
        ax.semilogy(pfa["snr_db"], pfa[f"inco_{n_b}"]["mc"], "o", color=col, ms=4)
        ax.semilogy(pfa["snr_db"], pfa[f"coh_{n_b}"]["theory"], "--", color=col,
                    label=f"coherent N_B={n_b} (2.45)")
        ax.semilogy(pfa["snr_db"], pfa[f"coh_{n_b}"]["mc"], "s", color=col, ms=4, mfc="none")
    ax.set(xlabel="SNR after beamforming, N_H N_DFT SNR_T (dB)",
           ylabel="Pr(noise ≥ signal)", ylim=(1e-4, 1.1))
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3, which="both")
    ax.set_title("Modified PFA (fig. 2.8): lines theory, markers Monte Carlo", fontsize=10)
    fig.tight_layout()
    fig.savefig(outdir / "psas_pfa_fig2_8.png", dpi=120)
    plt.close(fig)
    # fig 2.11
    fig, ax = plt.subplots(figsize=(7, 4.5))
    cone = extra["pert"]["cone"]
    for s, p in extra["pert"]["patterns"].items():
        ax.plot(cone, 10 * np.log10(np.maximum(p / p.max() if s == 0 else
                                               p / extra["pert"]["patterns"][0.0].max(), 1e-6)),
                label=f"σ = {s:g} λ")
    ax.set(xlabel="cone angle (deg)", ylabel="mean PSAS response (dB re ideal peak)",
           ylim=(-40, 2))
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    ax.set_title("PSAS beam pattern under lateral motion (fig. 2.11), N_B = 10")
    fig.tight_layout()
    fig.savefig(outdir / "psas_patterns_fig2_11.png", dpi=120)
    plt.close(fig)
    # fig 2.12
    fig, ax = plt.subplots(figsize=(6, 4.5))
    ax.plot(pert["sigma_lambda"], pert["psas_gain_db"], "o-", label="PSAS (no correction)")
    ax.plot(pert["sigma_lambda"], pert["etam_gain_db"], "s-", label="ETAM (eqs. 2.52-2.54)")
    ax.axhline(pert["ideal_db"], color="k", lw=0.8, ls=":", label="10 log10 N_B")
    ax.set(xlabel="lateral motion σ (wavelengths)", ylabel="synthetic aperture gain (dB)")
    ax.legend()
    ax.grid(alpha=0.3)
    ax.set_title(f"Synthetic aperture gain vs lateral motion (fig. 2.12), N_B = {pert['n_b']}")
    fig.tight_layout()
    fig.savefig(outdir / "psas_gain_fig2_12.png", dpi=120)
    plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", default=None, help="write the numbers here")
    ap.add_argument("--plot", default=None, help="directory for the figures")
    ap.add_argument("--quick", action="store_true", help="shorter recordings, fewer σ values")
    a = ap.parse_args()
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        res, extra = {}, {}
        res["ideal"], extra["ideal"] = ideal(tmp, a.quick)
        res["perturbed"], extra["pert"] = perturbed(tmp, a.quick)
        res["two_sources"] = two_sources(tmp, a.quick)
        res["ibf"] = ibf_alone(tmp, a.quick)
    res["seconds"] = time.perf_counter() - t0
    print(json.dumps({k: v for k, v in res.items() if k != "ideal"}, indent=1))
    i = res["ideal"]
    print("ideal gain (dB):", np.round(i["gain_db"], 2).tolist())
    print("beamwidth ratio:", np.round(i["beamwidth_ratio"], 2).tolist())
    print("PFA max |z|:", {k: round(v["max_z"], 2) for k, v in i["pfa"].items()
                           if isinstance(v, dict)})
    if a.json:
        Path(a.json).write_text(json.dumps(res, indent=1))
    if a.plot:
        plots(res, extra, Path(a.plot))


if __name__ == "__main__":
    main()
