#!/usr/bin/env python
"""Observability maps of BO-TMA and TD-TMA, thesis figs. 3.20-3.23.

For a grid of source initial positions (course and speed fixed) and a fixed receiver track,
the Fisher information of each method (thesis eq. (3.53), app. C.2 / C.3) gives the decadic
logarithm of its condition number (eq. (3.54)) and the initial-range standard deviation
(eq. (3.55)), blanked where the FIM is not positive definite. Two receiver tracks: two
five-minute legs separated by a 45° turn (fig. 3.20 → fig. 3.21) and a ten-minute straight
leg parallel to the source's track at the same course and speed (fig. 3.22 → fig. 3.23).
128 hydrophones 0.36 m apart, σ_τ = 1e-4 s, σ_θ = 0.0306° as in fig. 3.19. Sections along
the 45° initial bearing as in the thesis's lower panels.

Usage:
  python scripts/observability_maps.py [--extent 10000] [--n 81] [--json OUT] [--plot DIR]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from arrayproc.track.batch import scenarios as S
from arrayproc.track.batch.fim import bo_fim, condition_number, crlb_from_fim, range_sigma, td_fim

SIGMA_TAU = 1e-4
SIGMA_THETA = np.deg2rad(0.0306)
N_H, DX, C = 128, 0.36, 1500.0
SOURCE_VEL = np.array([0.0, 3.0])       # m/s: course 0°, 3 m/s (the ownship's first leg)


def maps(track: S.OwnTrack, states: np.ndarray) -> dict:
    """log10 condition number and range σ of both methods for states (G, 4)."""
    el = S.line_elements(track, N_H, DX)
    out = {}
    for m in ("bearings", "delays"):
        f = (bo_fim(states, track.time, track.position, SIGMA_THETA) if m == "bearings"
             else td_fim(states, track.time, el, 0, C, SIGMA_TAU))
        crlb, pd = crlb_from_fim(f)
        k = condition_number(f)
        rel = states[:, :2] - track.position[0]
        out[m] = {"log10_cond": np.log10(k), "range_sigma": range_sigma(rel, crlb), "pd": pd}
    return out


def run(extent: float, n: int) -> tuple[dict, dict]:
    g = np.linspace(-extent, extent, n)
    xx, yy = np.meshgrid(g, g)
    states = np.column_stack([xx.ravel(), yy.ravel(), np.full(xx.size, SOURCE_VEL[0]),
                              np.full(xx.size, SOURCE_VEL[1])])
    near = np.hypot(states[:, 0], states[:, 1]) < 200.0
    r = np.geomspace(300.0, 20000.0, 60)
    sec = np.column_stack([r * np.sin(np.pi / 4), r * np.cos(np.pi / 4),
                           np.full(r.size, SOURCE_VEL[0]), np.full(r.size, SOURCE_VEL[1])])
    scen = {"turn": S.turn_track(), "parallel": S.parallel_track()}
    grids, summary = {}, {"extent_m": extent, "n": n, "source_velocity_mps": SOURCE_VEL.tolist(),
                          "sigma_tau_s": SIGMA_TAU,
                          "sigma_theta_deg": float(np.rad2deg(SIGMA_THETA)),
                          "n_hydrophones": N_H, "spacing_m": DX}
    for name, tr in scen.items():
        t0 = time.perf_counter()
        mp = maps(tr, states)
        ms = maps(tr, sec)
        grids[name] = {"x": g, "maps": mp, "section_range": r, "section": ms, "near": near}
        s = {"seconds": time.perf_counter() - t0}
        for m in ("bearings", "delays"):
            pd = mp[m]["pd"] & ~near
            rs = mp[m]["range_sigma"][pd]
            s[m] = {"fraction_positive_definite": float(pd.sum() / (~near).sum()),
                    "median_log10_cond": float(np.median(mp[m]["log10_cond"][~near])),
                    "range_sigma_median_m": float(np.median(rs)) if rs.size else None,
                    "section_45deg": {f"{int(rr)} m": (None if not np.isfinite(v) else float(v))
                                      for rr, v in zip(r[::10], ms[m]["range_sigma"][::10],
                                                       strict=True)},
                    "section_45deg_log10_cond": {
                        f"{int(rr)} m": float(v) for rr, v in zip(
                            r[::10], ms[m]["log10_cond"][::10], strict=True)}}
        summary[name] = s
    return grids, summary


def plot(grids: dict, outdir: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    outdir.mkdir(parents=True, exist_ok=True)
    for name, gd in grids.items():
        tr = S.turn_track() if name == "turn" else S.parallel_track()
        g = gd["x"] / 1e3
        fig, axes = plt.subplots(3, 2, figsize=(10, 12))
        for col, m in enumerate(("bearings", "delays")):
            mp = gd["maps"][m]
            n = g.size
            # not positive definite: drawn at the top of the scale (round-off makes K of an
            # exactly singular J any huge number)
            kk = np.where(mp["pd"], mp["log10_cond"], 20.0)
            kk = np.where(gd["near"], np.nan, kk).reshape(n, n)
            rs = np.where(gd["near"], np.nan, mp["range_sigma"]).reshape(n, n)
            for row, (img, lab, lim) in enumerate(((kk, "log10 K(J) (≥ 20: not PD)", (5, 20)),
                                                   (np.log10(rs), "log10 σ_r (m)", (0, 4)))):
                ax = axes[row, col]
                im = ax.pcolormesh(g, g, img, vmin=lim[0], vmax=lim[1], cmap="viridis",
                                   shading="auto")
                ax.plot(tr.position[:, 0] / 1e3, tr.position[:, 1] / 1e3, "w-", lw=2)
                ax.set_aspect("equal")
                ax.set_xlabel("source initial x east (km)")
                ax.set_ylabel("source initial y north (km)")
                ax.set_title(f"{'BO-TMA' if m == 'bearings' else 'TD-TMA'}: {lab}"
                             + ("\n(white: not positive definite)" if row == 1 else ""))
                fig.colorbar(im, ax=ax, label=lab)
            ax = axes[2, col]
            sec = gd["section"][m]
            r = gd["section_range"] / 1e3
            ax.semilogy(r, sec["range_sigma"], "k-", label="σ_r (m)")
            ax2 = ax.twinx()
            ax2.plot(r, np.where(sec["pd"], sec["log10_cond"], np.nan),
                     "r--", label="log10 K(J)")
            ax2.set_ylabel("log10 K(J)", color="r")
            ax.set_xlabel("initial range at bearing 45° (km)")
            ax.set_ylabel("σ_r (m)")
            ax.set_title("section at 45° (σ_r blank where not PD)")
            if not np.any(sec["pd"]):
                ax.text(0.5, 0.5, "FIM not positive definite\nat any range", ha="center",
                        transform=ax.transAxes)
            ax.grid(True, which="both", alpha=0.3)
        fig.suptitle(f"Thesis fig. {'3.21' if name == 'turn' else '3.23'}: {name} scenario "
                     "(source course 0°, 3 m/s)")
        fig.tight_layout()
        fig.savefig(outdir / f"observability_{name}.png", dpi=100)
        plt.close(fig)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--extent", type=float, default=10000.0, help="grid half-width, m")
    ap.add_argument("--n", type=int, default=81, help="grid nodes per axis")
    ap.add_argument("--json", default=None)
    ap.add_argument("--plot", default=None, help="directory for the PNG figures")
    a = ap.parse_args()
    grids, summary = run(a.extent, a.n)
    for name in ("turn", "parallel"):
        for m in ("bearings", "delays"):
            s = summary[name][m]
            print(f"{name:8s} {m:8s}: PD at {s['fraction_positive_definite']:.1%} of positions, "
                  f"median log10 K {s['median_log10_cond']:.1f}, median σ_r "
                  f"{s['range_sigma_median_m']} m; 45° section σ_r {s['section_45deg']}")
    if a.json:
        Path(a.json).write_text(json.dumps(summary, indent=1))
    if a.plot:
        plot(grids, Path(a.plot))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
