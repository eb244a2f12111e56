"""Line-contacts plot: frequency against time and bearing against time, coloured by SNR."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from arrayproc.plots import register_plot
from arrayproc.plots._passive import find_group, open_truth_recording

#: Truth colours that stand out on the SNR colour map (viridis).
TRUTH_COLOURS = ("tab:red", "tab:orange", "magenta", "black", "tab:brown")


def _truth(root: dict, t: np.ndarray) -> dict[str, tuple[np.ndarray, np.ndarray]] | None:
    """``{source: (tonal frequencies (n_t, n_tonals) Hz, true bearing (n_t,) deg)}`` from the
    products' recording when it has /truth, else None."""
    rec = open_truth_recording(root)
    if rec is None:
        return None
    from arrayproc.io.truth import relative_bearings, tonal_frequencies
    with rec:
        _, heading, _, _ = rec.nav.at(t)
        rel = relative_bearings(rec, t)
        tonals = tonal_frequencies(rec, t)
        return {name: (tonals.get(name, np.zeros((t.size, 0))),
                       (np.asarray(heading, float) + r) % 360.0) for name, r in rel.items()}


@register_plot("lines")
def plot_lines(path: str, out_png: str, truth: bool = True, range_db: float | None = None,
               beam: float | None = None) -> None:
    """Draw the first ``lines`` group of ``path`` into ``out_png``: frequency against time
    (top) and both left-right bearings against time (bottom; starboard mirror filled, port
    mirror hollow), coloured by SNR over the TPSW background. With truth, each source's
    Doppler-shifted tonal frequencies and its true bearing are drawn as dashed lines
    (``range_db`` and ``beam``, options of the image plots, do not apply)."""
    import matplotlib.pyplot as plt

    g, root = find_group(path, "lines")
    t, f, snr = g["time"], g["freq_hz"], g["snr_db"]
    fig, (ax_f, ax_b) = plt.subplots(2, 1, figsize=(9.0, 8.5), dpi=110, sharex=True)
    lo, hi = (float(np.min(snr)), float(np.max(snr))) if snr.size else (0.0, 1.0)
    kw = dict(c=snr, cmap="viridis", vmin=lo, vmax=max(hi, lo + 1.0), s=14)
    sc = ax_f.scatter(t, f, **kw)
    ax_b.scatter(t, g["bearing_stbd_deg"], label="starboard mirror", **kw)
    ax_b.scatter(t, g["bearing_port_deg"], marker="o", facecolors="none",
                 edgecolors=plt.get_cmap("viridis")((snr - lo) / max(hi - lo, 1.0)),
                 s=14, label="port mirror")
    tt = np.unique(t)
    tru = _truth(root, tt) if truth and tt.size else None
    for i, (name, (fr, brg)) in enumerate((tru or {}).items()):
        col = TRUTH_COLOURS[i % len(TRUTH_COLOURS)]
        for k in range(fr.shape[1]):
            ax_f.plot(tt, fr[:, k], ls="--", lw=0.9, color=col,
                      label=f"truth: {name}" if k == 0 else None)
        wrap = np.r_[False, np.abs(np.diff(brg)) > 180.0]
        ax_b.plot(tt, np.where(wrap, np.nan, brg), ls="--", lw=0.9, color=col,
                  label=f"truth: {name}")
    cb = fig.colorbar(sc, ax=[ax_f, ax_b], pad=0.02)
    cb.set_label("SNR over TPSW background (dB)")
    ax_f.set_ylabel("frequency (Hz)")
    ax_b.set_ylabel("bearing (deg true)")
    ax_b.set_ylim(0.0, 360.0)
    ax_b.set_xlabel("time (s since recording start)")
    for ax in (ax_f, ax_b):
        if ax.get_legend_handles_labels()[0]:
            ax.legend(loc="upper right", fontsize=7, framealpha=0.7)
        ax.grid(alpha=0.3)
    ax_f.set_title(f"line contacts ({t.size} contacts)\n{Path(path).name}", fontsize=10)
    fig.savefig(out_png)
    plt.close(fig)
