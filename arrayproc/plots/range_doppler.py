"""Range-Doppler map of one ping on one beam (the ``range_doppler`` product of the
``matched_filter`` stage, thesis figs. 4.1 / 4.7): |chi|^2 in dB re its peak, fixed dynamic
range, range across and range rate up; true echoes of the ping within 3 deg of the beam drawn when
the source recording holds ``/truth/echoes`` (range from the array at reception, as the
contacts')."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from arrayproc.errors import ArrayprocError
from arrayproc.plots import register_plot
from arrayproc.plots._passive import find_group


@register_plot("range_doppler")
def plot_range_doppler(path: str, out_png: str, range_db: float = 30.0, ping: int | None = None,
                       cone: float | None = None, truth: bool = True,
                       beam: float | None = None) -> None:
    """Draw one row of the first ``range_doppler`` group of ``path`` into ``out_png``.

    ``ping`` and ``cone`` (deg; ``beam``, the ``plot`` command's ``--beam``, is the same) pick
    the row (default: the first row); the colour scale spans ``range_db`` dB below the map's
    peak.
    """
    if cone is None:
        cone = beam
    import matplotlib.pyplot as plt

    g, root = find_group(path, "range_doppler")
    pings = np.asarray(g["ping"]).reshape(-1)
    cones = np.asarray(g["cone_deg"], float).reshape(-1)
    rows = np.arange(pings.size)
    if ping is not None:
        rows = rows[pings[rows] == ping]
    if cone is not None and rows.size:
        rows = rows[np.argsort(np.abs(cones[rows] - cone), kind="stable")]
    if rows.size == 0:
        raise ArrayprocError(f"{path}: no range_doppler row for ping {ping}")
    i = int(rows[0])
    rng = np.asarray(g["range_m"][i], float)
    rr = np.asarray(g["range_rate_mps"][i], float)
    lev = np.asarray(g["level_db"][i], float)
    lev = lev - np.nanmax(lev)
    fig, ax = plt.subplots(figsize=(8.0, 5.0), dpi=110)
    drr = rr[1] - rr[0] if rr.size > 1 else 1.0
    im = ax.imshow(lev, aspect="auto", origin="lower", cmap="viridis", vmin=-range_db, vmax=0,
                   extent=[rng[0], rng[-1], rr[0] - drr / 2, rr[-1] + drr / 2],
                   interpolation="nearest")
    cb = fig.colorbar(im, ax=ax, pad=0.02)
    cb.set_label(f"|χ|², dB re peak ({range_db:g} dB range)")
    src = root.get("source", "")
    src = src.decode() if isinstance(src, bytes) else str(src)
    if truth and src and Path(src).is_file():
        from arrayproc.io.recording import Recording
        from arrayproc.io.truth import echo_truth
        with Recording(src) as rec:
            tr = echo_truth(rec)
        if tr is not None:
            ra = tr["range_array_m"]
            m = ((tr["ping"] == pings[i]) & (ra >= rng.min()) & (ra <= rng.max())
                 & (np.abs(tr["cone_deg"] - cones[i]) < 3.0))
            for r, v, n in zip(ra[m], tr["range_rate_mps"][m], tr["name"][m]):
                ax.plot(r, v, "o", mfc="none", mec="w", ms=12, mew=1.2)
                ax.annotate(f"truth: {n}", (r, v), xytext=(8, 8), textcoords="offset points",
                            color="w", fontsize=8)
    ax.set_xlabel("range from the array (m)")
    ax.set_ylabel("range rate (m/s, positive opening)")
    ax.set_title(f"range-Doppler, ping {int(pings[i])}, cone {cones[i]:.1f} deg\n"
                 f"{Path(path).name}", fontsize=10)
    fig.tight_layout()
    fig.savefig(out_png)
    plt.close(fig)
