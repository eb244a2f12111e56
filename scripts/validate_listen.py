"""The listening beam against the closed-form pattern: the table and figure of
docs/validation/beamformers.md ("Listening to a beam").

    python scripts/validate_listen.py [--step 2] [--figure docs/figures/listen_pattern.png]
"""

from __future__ import annotations

import argparse

import numpy as np

from arrayproc.evaluate.scenarios.listen import pattern_sweep


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--step", type=float, default=2.0, help="cone step of the sweep, deg")
    p.add_argument("--figure", default="docs/figures/listen_pattern.png", help="PNG to write")
    a = p.parse_args()
    cones = np.unique(np.r_[np.arange(0.0, 180.0 + 1e-9, a.step), 60.0, 110.0])
    r = pattern_sweep(cones)
    (c1, f1), (c2, f2) = r["tonals"]
    print("| beam cone | tonal | measured dB | eq. 2.13 dB |")
    print("| --- | --- | --- | --- |")
    for beam in (c1, c2):
        j = int(np.argmin(np.abs(cones - beam)))
        for i, (c, f) in enumerate(r["tonals"]):
            print(f"| {beam:g}° | {f:g} Hz from {c:g}° | {r['measured_db'][i, j]:.2f} | "
                  f"{r['closed_db'][i, j]:.2f} |")
    ok = r["closed_db"] > -40  # above the noise floor of the beam
    err = np.abs(r["measured_db"] - r["closed_db"])[ok]
    print(f"max |measured - closed| where the pattern is above -40 dB: {err.max():.3f} dB "
          f"({ok.sum()} points)")
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(8, 4.2))
    for i, (c, f) in enumerate(r["tonals"]):
        line, = ax.plot(cones, r["closed_db"][i], lw=1.2,
                        label=f"eq. 2.13, {f:g} Hz from {c:g}°")
        ax.plot(cones, r["measured_db"][i], "o", ms=3, color=line.get_color(),
                label=f"measured in the WAV beam, {f:g} Hz")
        ax.axvline(c, color=line.get_color(), ls=":", lw=0.8)
    ax.set_xlabel("beam cone angle θ (deg, 0 = forward end-fire)")
    ax.set_ylabel("tonal level in the beam (dB re its level at a hydrophone)")
    ax.set_ylim(-60, 3)
    ax.set_xlim(0, 180)
    ax.set_title("listen: delay-and-sum beam of a 16-element line array (δx 0.75 m)")
    ax.legend(fontsize=7, loc="lower right")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(a.figure, dpi=110)
    print(f"wrote {a.figure}")


if __name__ == "__main__":
    main()
