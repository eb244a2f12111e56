"""The figure of :mod:`arrayproc.evaluate.spl_recording` (docs/validation/spl_recording.md):
position RMSE against time from recordings and at measurement level, and the products'
errors against time."""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["plot_rmse"]


def plot_rmse(res: dict[str, Any], path: str) -> None:
    """Top: position RMSE against time of the recordings' tracks (bearings only, with
    levels), of the measurement-level Monte Carlo (the paper's σ's; the recordings' mean
    errors and residual σ's; the residual σ's alone) and the paper's fig. 3 values
    (:data:`~arrayproc.evaluate.scenarios.spl_paper.PAPER`). Bottom: the products' mean
    bearing and level errors against time with the bearing and heading sweeps of one
    integration."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from arrayproc.evaluate.scenarios.spl_paper import PAPER

    fig, (ax, bx) = plt.subplots(2, 1, figsize=(12.0, 9.0), sharex=True,
                                 gridspec_kw={"height_ratios": [3, 2]})
    n = len(res["seeds"])
    mcs = (("measurement_level_paper", "--", "paper σ"),
           ("measurement_level_recording", ":", "rec. mean errors + residual σ"),
           ("measurement_level_residual", "-.", "rec. residual σ only"))
    for label, col in (("bot", "tab:blue"), ("spl", "tab:red")):
        name = "BOT" if label == "bot" else "BOT+SPL"
        ax.plot(res["time_min"], res[f"rmse_{label}_m"], "-o", color=col, ms=3, lw=2,
                label=f"recording {name} ({n} seeds)")
        if f"rmse_known_side_{label}_m" in res:
            ax.plot(res["time_min"], res[f"rmse_known_side_{label}_m"], "-x", color=col,
                    ms=4, lw=0.8, label=f"recording {name}, true side of each pair")
        for key, ls, what in mcs:
            mc = res.get(key)
            if mc:
                ax.plot(mc["time_min"], mc[f"rmse_{label}_m"], ls, color=col, lw=1,
                        label=f"meas. level {name}, {what} ({mc['runs']} runs)")
        pts = list(PAPER["manoeuvring"].values())
        ax.plot([p[0] for p in pts], [p[1 if label == "bot" else 2] for p in pts], "*",
                color=col, ms=13, mec="k", ls="none", label=f"paper fig. 3 {name}")
    for a in (ax, bx):
        a.axvspan(13.0, 17.0, color="0.9", zorder=0)
        a.grid(True, which="both", alpha=0.3)
    ax.set_yscale("log")
    ax.set_ylabel("position RMSE (m)")
    ax.set_title("SPL paper, manoeuvring observer (turn shaded): RPF from recordings")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.08, 1.0))
    tm = np.asarray(res["time_min"])
    bx.plot(tm, res["bearing_err_mean_by_time_deg"], "-o", ms=3, color="tab:green",
            label="bearing error, mean over seeds (deg)")
    if "elevation_bearing_err_deg" in res["sweeps"]:
        bx.plot(tm, res["sweeps"]["elevation_bearing_err_deg"], "-", lw=3, alpha=0.4,
                color="tab:olive", label="bearing error of the arrival's elevation "
                "(cone angle read as bearing, deg)")
    bx.plot(tm, res["level_err_mean_by_time_db"], "-s", ms=3, color="tab:purple",
            label="level error spl_db − (SL − TL), mean over seeds (dB)")
    bx.axhline(0.0, color="k", lw=0.5)
    bx.set_ylabel("error (deg or dB)")
    bx.set_xlabel("time (min)")
    cx = bx.twinx()
    sw = res["sweeps"]
    cx.plot(tm, np.abs(sw["bearing_sweep_deg"]), "--", color="0.4",
            label="|true bearing change| in one 60-s integration (deg)")
    cx.plot(tm, np.abs(sw["heading_sweep_deg"]), ":", color="0.2",
            label="|heading change| in one 60-s integration (deg)")
    cx.set_ylabel("change in one integration (deg)")
    h1, l1 = bx.get_legend_handles_labels()
    h2, l2 = cx.get_legend_handles_labels()
    bx.legend(h1 + h2, l1 + l2, fontsize=7, loc="upper left")
    fig.tight_layout()
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
