"""Figures of docs/validation/realism.md: Lloyd's mirror level against range (simulated and
two-path closed form), the water-pulled array in a turn (truth shape, threaded estimate from
/nav, rigid layout), bottom reverberation level against the sonar equation.

    .venv/bin/python scripts/plot_realism.py [--out docs/figures/realism] [--seeds 4]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from arrayproc.evaluate.scenarios import realism as rz  # noqa: E402


def lloyd(ax) -> None:
    from arrayproc.sim.run import Simulator
    from arrayproc.sim.sources import tonal_amplitude
    zs, zr, f, fs = 20.0, 50.0, 1000.0, 4096.0
    r = np.linspace(100.0, 3000.0, 600)
    sim = Simulator(rz.ranged_scenario(r, zs, zr, {"surface": True, "order": 1}))
    x = sim.render(0, 2048).astype(float)
    meas = 20 * np.log10(np.abs(rz.tonal_phasor(x, f, fs)) / tonal_amplitude(120.0))
    cf = 20 * np.log10(np.abs(rz.two_path(r, zs, zr, f, -1.0)))
    ax.plot(r, cf, "k-", lw=2.5, alpha=0.35, label="two-path closed form")
    ax.plot(r, meas, "C0.", ms=2.5, label="simulated (600 hydrophones)")
    ax.plot(r, -20 * np.log10(r), "C3--", lw=1, label="free field, −20 log10 r")
    ax.set_xlabel("range (m)")
    ax.set_ylabel("level re source level (dB)")
    ax.set_title("Lloyd's mirror, 1 kHz, z_s = 20 m, z_r = 50 m")
    ax.set_ylim(-110, -30)
    ax.legend(fontsize=8, loc="lower left")


def shape(ax, ax2, tmp: Path) -> None:
    from arrayproc.geo.threading import threaded_positions
    from arrayproc.io.recording import Recording
    from arrayproc.sim.run import simulate_file
    (tmp / "s.toml").write_text(rz.turn_scenario(100.0))
    rec_path = simulate_file(tmp / "s.toml", tmp / "rec.h5")
    with Recording(rec_path) as rec:
        truth = rec.read_group("truth/array")
        own = rec.read_group("truth/ownship")
        ax.plot(own["position"][:, 0], own["position"][:, 1], "k:", lw=1,
                label="reference point track")
        for i, t in enumerate((15.0, 55.0, 90.0)):
            k = int(np.argmin(np.abs(truth["shape_time"] - t)))
            ep = truth["element_positions"][k]
            _, w = threaded_positions(rec.nav, rec.positions, np.array([t]))
            rg = rec.pose(t).elements
            lab = i == 0
            ax.plot(ep[:, 0], ep[:, 1], "C0o", ms=3, label="truth shape" if lab else None)
            ax.plot(w[0, :, 0], w[0, :, 1], "C1-", lw=1.5,
                    label="threaded from /nav" if lab else None)
            ax.plot(rg[:, 0], rg[:, 1], "C3--", lw=1, label="rigid layout" if lab else None)
            ax.annotate(f"t = {t:g} s", ep[0, :2], fontsize=8, xytext=(5, 5),
                        textcoords="offset points")
            n = np.arange(ep.shape[0])
            ax2.plot(n, np.linalg.norm(ep - rg, axis=1), f"C{i}o", ms=3,
                     label=f"truth − rigid, t = {t:g} s")
            ax2.plot(n, 100 * np.linalg.norm(w[0] - ep, axis=1), f"C{i}-", lw=1,
                     label=f"threaded − truth × 100, t = {t:g} s")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x east (m)")
    ax.set_ylabel("y north (m)")
    ax.set_title("water-pulled 46.5 m array, 1.5°/s turn")
    ax.legend(fontsize=8, loc="lower left")
    ax2.set_xlabel("element (0 forward)")
    ax2.set_ylabel("distance (m)")
    ax2.set_title("bend: truth against rigid, threaded error ×100")
    ax2.legend(fontsize=7)


def reverb(ax, seeds: int) -> None:
    from arrayproc.sim.run import Simulator
    from arrayproc.sim.scenario import parse_scenario
    depth, zr, mu_db, pulse, half = 100.0, 20.0, -27.0, 0.01, 700.0
    rv = {"boundary": "bottom", "depth": depth, "scattering_strength_db": mu_db,
          "density": 0.002, "area": [-half, half, -half, half]}
    dur = 0.1 + 2 * 650.0 / rz.C + 0.05
    p2 = []
    for seed in range(seeds):
        sim = Simulator(parse_scenario(rz.active_scenario({"reverberation": [rv]}, dur, seed, pulse,
                                                  zr)))
        p2.append(sim.render(0, sim.n_samples)[:, 0].astype(float) ** 2)
    p2 = np.mean(p2, axis=0)
    t = np.arange(p2.size) / rz.FS - 0.1
    cf = rz.sonar_equation_intensity(t, 200.0, mu_db, depth, zr, pulse)
    k = 41  # 10 ms running mean
    sm = np.convolve(p2, np.ones(k) / k, mode="same")
    sel = t > 0.12
    ax.plot(t[sel], 10 * np.log10(sm[sel] / 1e-12), "C0-", lw=0.8,
            label=f"simulated, {seeds} seeds, 10 ms mean")
    ax.plot(t[sel], 10 * np.log10(cf[sel] / 1e-12), "k-", lw=2, alpha=0.6,
            label="sonar equation (Lambert)")
    ax.set_xlabel("time after the ping (s)")
    ax.set_ylabel("reverberation level (dB re 1 µPa²)")
    ax.set_title("bottom reverberation, μ = −27 dB, 10 ms CW")
    ax.legend(fontsize=8)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "docs/figures/realism"))
    ap.add_argument("--seeds", type=int, default=4)
    args = ap.parse_args()
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    fig, axs = plt.subplots(1, 4, figsize=(22, 5.2))
    lloyd(axs[0])
    with tempfile.TemporaryDirectory() as tmp:
        shape(axs[1], axs[2], Path(tmp))
    reverb(axs[3], args.seeds)
    fig.tight_layout()
    fig.savefig(out / "realism.png", dpi=110)
    print(out / "realism.png")


if __name__ == "__main__":
    main()
