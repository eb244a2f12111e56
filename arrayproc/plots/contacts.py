"""Active contacts (the ``cfar`` stage's ``contacts`` product): (left) range against cone angle
coloured by absolute Doppler (thesis eq. (4.9), fixed +-5 m/s scale), moving contacts ringed,
the true submarine echoes marked when the source recording holds ``/truth/echoes``; (right) the
empirical CDF of |absolute Doppler| of the clutter contacts, in knots, with the ``moving``
threshold (thesis fig. 4.10 analogue: the fraction left of the threshold is the fraction
correctly classified as not moving). With truth, clutter contacts are those within 5 m and
3 deg of a static scatterer's echo; without, every contact of a Doppler-sensitive ping."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from arrayproc.plots import register_plot
from arrayproc.plots._passive import find_group

KNOT = 1852.0 / 3600.0


@register_plot("contacts")
def plot_contacts(path: str, out_png: str, doppler_mps: float = 5.0, threshold_kn: float = 2.0,
                  snr_min_db: float = 15.0, truth: bool = True, range_db: float | None = None,
                  beam: float | None = None) -> None:
    """Draw the first ``contacts`` group of ``path`` into ``out_png``.

    ``range_db`` and ``beam`` (the ``plot`` command's options) are unused here.

    ``doppler_mps`` sets the colour scale (+-, m/s); ``threshold_kn`` the ECDF's marker; only
    contacts of at least ``snr_min_db`` are drawn (the thesis's fig. 4.10 takes the contacts
    "exceeding a preset SNR threshold"; the CFAR's own false alarms sit just above its
    threshold, 12-13 dB at pfa 1e-6).
    """
    import matplotlib.pyplot as plt

    g, root = find_group(path, "contacts")
    c = {k: np.asarray(v) for k, v in g.items() if k not in ("attrs", "kind", "stage")}
    n_all = c["range_m"].size
    keep = c["snr_db"] >= snr_min_db
    c = {k: v[keep] for k, v in c.items()}
    wv = np.array([w.decode() if isinstance(w, bytes) else str(w) for w in c["waveform"]])
    src = root.get("source", "")
    src = src.decode() if isinstance(src, bytes) else str(src)
    tr = None
    if truth and src and Path(src).is_file():
        from arrayproc.io.recording import Recording
        from arrayproc.io.truth import echo_truth
        with Recording(src) as rec:
            tr = echo_truth(rec)
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(12.0, 5.5), dpi=110,
                                 gridspec_kw={"width_ratios": [1.35, 1.0]})
    ins = (wv == "hfm") | (wv == "lfm")  # Doppler insensitive: no measured Doppler
    if ins.any():
        ax.scatter(c["cone_deg"][ins], c["range_m"][ins], s=10, marker="x", color="0.45",
                   lw=0.7, zorder=2, label="HFM/LFM contacts (no Doppler)")
    sc = ax.scatter(c["cone_deg"][~ins], c["range_m"][~ins],
                    c=c["absolute_doppler_mps"][~ins], s=14, cmap="coolwarm",
                    vmin=-doppler_mps, vmax=doppler_mps, zorder=3)
    mv = c["moving"].astype(bool)
    ax.scatter(c["cone_deg"][mv], c["range_m"][mv], s=70, facecolors="none",
               edgecolors="k", linewidths=0.8, zorder=4, label="moving")
    cb = fig.colorbar(sc, ax=ax, pad=0.02)
    cb.set_label("absolute Doppler (m/s, eq. 4.9)")
    clutter = np.ones(c["range_m"].size, bool)
    if tr is not None:
        from arrayproc.evaluate.association import associate
        tg = tr["kind"] == "target"
        ax.plot(tr["cone_deg"][tg], tr["range_m"][tg], "k+", ms=12, mew=1.5, zorder=5,
                label="truth: target echoes")
        idx = associate(c, tr, range_gate=5.0, cone_gate=3.0)
        clutter = (idx >= 0) & (tr["kind"][np.maximum(idx, 0)] == "clutter")
    ax.set_xlabel("cone angle (deg; 0 = forward end-fire)")
    ax.set_ylabel("range (m)")
    ax.set_xlim(0, 180)
    ax.legend(loc="upper right", fontsize=8)
    ax.set_title(f"contacts with SNR >= {snr_min_db:g} dB: {c['range_m'].size} of {n_all}, "
                 f"{np.unique(c['ping']).size} pings\n{Path(path).name}", fontsize=10)
    sens = clutter & (wv != "hfm") & (wv != "lfm")
    a = np.sort(np.abs(c["absolute_doppler_mps"][sens]) / KNOT)
    if a.size:
        bx.step(a, np.arange(1, a.size + 1) / a.size, where="post", color="C0")
        frac = float(np.mean(a <= threshold_kn))
        bx.axvline(threshold_kn, color="k", ls="--", lw=1)
        bx.annotate(f"{100 * frac:.1f} % below {threshold_kn:g} kn (n = {a.size})",
                    (threshold_kn, frac), xytext=(10, -20), textcoords="offset points",
                    fontsize=9)
    bx.set_xlim(0, max(6.0, 2.5 * threshold_kn))
    bx.set_ylim(0, 1.02)
    bx.grid(True, alpha=0.4)
    bx.set_xlabel("|absolute Doppler| (kn)")
    bx.set_ylabel("empirical CDF")
    who = "clutter (truth-associated)" if tr is not None else "all"
    bx.set_title(f"ECDF of |absolute Doppler|, {who} contacts", fontsize=10)
    fig.tight_layout()
    fig.savefig(out_png)
    plt.close(fig)
