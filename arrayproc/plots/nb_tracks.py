"""Narrowband EKF plot (thesis figs. 3.8-3.10): cone angle, cone error and received frequency
against time (time running down) for the Kalman tracker and the CBF baseline with the truth,
and the ECDF and EPDF of the cone error.

:func:`draw_nb_tracks` takes arrays (used by ``scripts/reproduce_nb_ekf.py``); the registered
plotter reads the ``nb_tracks`` groups of a products file (an ``nb_ekf`` stage's group and, with
``baseline = true``, its ``<name>_cbf`` group) and the truth of the recording named by the
products, when it has one.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from arrayproc.errors import ArrayprocError
from arrayproc.plots import finish, register_plot, subplots, write_figure

#: EPDF range, deg (the thesis truncates the error at 2.5°).
EPDF_LIMIT_DEG = 2.5
#: Colours: Kalman red and CBF black as in the thesis, the single filter orange.
COLOURS = {"KAL": "tab:red", "KAL single": "tab:orange", "CBF": "black"}
#: Drawing order: the Kalman output on top.
ZORDER = {"KAL": 3, "KAL single": 2, "CBF": 1}
#: Frequency panels span the truth ± this (one LOFAR bin of 2048 points at 5120 Hz), Hz.
FREQ_MARGIN_HZ = 2.5
#: Most points drawn per time series.
MAX_POINTS = 20000
#: Figure size, resolution and panels of the narrowband plot.
LAYOUT = {"figsize": (14.0, 9.0), "dpi": 100, "nrows": 2, "ncols": 3}


def _thin(n: int) -> slice:
    return slice(None, None, max(1, n // MAX_POINTS))


def draw_nb_tracks(estimators: dict[str, dict[str, np.ndarray]],
                   truth: dict[str, np.ndarray] | None,
         out_png: str | Path | None = None, title: str = "", settle_s: float = 10.0,
         axes: Any = None) -> Any:
    """Draw the narrowband figure into ``out_png``, or on ``axes`` (a 2 x 3 array of
    matplotlib Axes; default: a new figure), returning the Figure.

    Parameters
    ----------
    estimators : dict
        Label -> ``{"time": s, "cone_deg": deg, "freq_hz": received Hz (optional)}``.
    truth : dict or None
        ``{"time": s, "cone_deg": deg, "freq_hz": received Hz}`` (interpolated to each
        estimator's times for the error panels).
    out_png : path, optional
        Output image.
    title : str
        Figure title.
    settle_s : float
        Start-up excluded from the ECDF/EPDF, s.
    axes : 2 x 3 array of matplotlib Axes, optional
        Where to draw when there is no ``out_png``.

    Returns
    -------
    matplotlib Figure, or None when written to ``out_png``
    """
    if out_png is not None and axes is None:
        write_figure(lambda a: draw_nb_tracks(estimators, truth, None, title, settle_s, a),
                     str(out_png), LAYOUT)
        return None
    fig, axs, new = subplots(axes, LAYOUT)
    a_cone, a_err, a_freq = axs[0]
    a_ecdf, a_epdf, a_ferr = axs[1]
    t_all = np.concatenate([e["time"] for e in estimators.values()])
    t0, t1 = float(t_all.min()), float(t_all.max())
    for label, e in estimators.items():
        col = COLOURS.get(label, None)
        z = ZORDER.get(label, 2)
        t = e["time"]
        s = _thin(t.size)
        a_cone.plot(e["cone_deg"][s], t[s], ".", ms=1.0, color=col, label=label, zorder=z)
        if e.get("freq_hz") is not None:
            a_freq.plot(e["freq_hz"][s], t[s], ".", ms=1.0, color=col, label=label, zorder=z)
        if truth is None:
            continue
        ct = np.interp(t, truth["time"], truth["cone_deg"])
        err = e["cone_deg"] - ct
        a_err.plot(err[s], t[s], ".", ms=1.0, color=col, label=label, zorder=z)
        ok = t >= t0 + settle_s
        ae = np.sort(np.abs(err[ok]))
        a_ecdf.plot(ae, np.arange(1, ae.size + 1) / ae.size, color=col, label=label, zorder=z)
        bins = np.linspace(-EPDF_LIMIT_DEG, EPDF_LIMIT_DEG, 201)
        h, edges = np.histogram(np.clip(err[ok], -EPDF_LIMIT_DEG, EPDF_LIMIT_DEG), bins=bins,
                                density=True)
        a_epdf.plot(0.5 * (edges[1:] + edges[:-1]), h, color=col, label=label, zorder=z)
        if e.get("freq_hz") is not None and truth.get("freq_hz") is not None:
            ft = np.interp(t, truth["time"], truth["freq_hz"])
            a_ferr.plot((e["freq_hz"] - ft)[s], t[s], ".", ms=1.0, color=col, label=label, zorder=z)
    if truth is not None:
        a_cone.plot(truth["cone_deg"], truth["time"], "--", lw=1.0, color="tab:blue",
                    label="truth")
        if truth.get("freq_hz") is not None:
            a_freq.plot(truth["freq_hz"], truth["time"], "--", lw=1.0, color="tab:blue",
                        label="truth")
    for a, xl in ((a_cone, "cone angle (deg, 0 = forward end-fire)"),
                  (a_err, "cone error (deg)"), (a_freq, "received frequency (Hz)"),
                  (a_ferr, "received frequency error (Hz)")):
        a.set_xlabel(xl)
        a.set_ylabel("time (s)")
        a.set_ylim(t1, t0)  # sonar orientation: time runs down
        a.grid(alpha=0.3)
    a_err.set_xlim(-EPDF_LIMIT_DEG, EPDF_LIMIT_DEG)
    if truth is not None and truth.get("freq_hz") is not None:
        fr = np.asarray(truth["freq_hz"], float)
        a_freq.set_xlim(np.nanmin(fr) - FREQ_MARGIN_HZ, np.nanmax(fr) + FREQ_MARGIN_HZ)
    a_ferr.set_xlim(-FREQ_MARGIN_HZ, FREQ_MARGIN_HZ)
    a_ecdf.set_xscale("log")
    a_ecdf.set_xlim(1e-3, 10.0)
    a_ecdf.set_ylim(0.0, 1.0)
    a_ecdf.axvline(0.5, color="grey", lw=0.8, ls=":")
    a_ecdf.set_xlabel("|cone error| (deg)")
    a_ecdf.set_ylabel("ECDF")
    a_ecdf.grid(alpha=0.3, which="both")
    a_epdf.set_xlim(-EPDF_LIMIT_DEG, EPDF_LIMIT_DEG)
    a_epdf.set_xlabel("cone error (deg, clipped at ±2.5)")
    a_epdf.set_ylabel("EPDF (1/deg)")
    a_epdf.grid(alpha=0.3)
    for a in (a_cone, a_freq, a_ecdf, a_epdf):
        if a.get_legend_handles_labels()[0]:
            a.legend(fontsize=8, markerscale=6, loc="best")
    a_cone.set_title("cone angle")
    a_err.set_title("cone error")
    a_freq.set_title("frequency")
    a_ecdf.set_title(f"ECDF of |cone error| after {settle_s:g} s")
    a_epdf.set_title("EPDF of cone error")
    a_ferr.set_title("frequency error")
    if title:
        fig.suptitle(title)
    return finish(fig, new, LAYOUT)


def _truth_from_recording(root: dict, t: np.ndarray, cone: np.ndarray, freq: np.ndarray):
    """Truth of the source (and tonal) nearest the track, from the products' recording."""
    from arrayproc.io.truth import cone_angles, tonal_frequencies
    from arrayproc.plots._passive import open_truth_recording

    rec = open_truth_recording(root)
    if rec is None:
        return None, None
    with rec:
        cones = cone_angles(rec, t)
        tonals = tonal_frequencies(rec, t)
        _, _, _, speed = rec.nav.at(t)
        c = rec.sound_speed
    best, cost = None, np.inf
    for name, ct in cones.items():
        fr = tonals.get(name)
        if fr is None:
            continue
        fs = fr / (1.0 + speed[:, None] * np.cos(np.radians(ct))[:, None] / c)
        k = int(np.argmin(np.nanmedian(np.abs(fs - freq[:, None]), axis=0)))
        j = float(np.nanmedian(np.abs(ct - cone))) + float(np.nanmedian(np.abs(fs[:, k] - freq)))
        if j < cost:
            best, cost = {"time": t, "cone_deg": ct, "freq_hz": fr[:, k]}, j
    return best, (speed, c)


@register_plot("nb_tracks")
def plot_nb_tracks(path: str, out_png: str, truth: bool = True, **_other: Any) -> None:
    """Draw every ``nb_tracks`` group of the products file ``path`` into ``out_png`` (see the
    module docstring); frequencies are shown as received (own Doppler added back with the
    recording's navigation when it is known). Options of the image plots (``range_db``,
    ``beam``) do not apply and are ignored."""
    from arrayproc.io.products import read_products

    prod = read_products(path)
    root = prod.root
    tracks = {name: g for name, g in prod.groups("nb_tracks").items() if "time" in g}
    if not tracks:
        raise ArrayprocError(f"{path}: no nb_tracks product with rows")
    first = next(iter(tracks.values()))
    tr, nav = (_truth_from_recording(root, first["time"], first["cone_deg"], first["freq_hz"])
               if truth else (None, None))
    est = {}
    for name, g in tracks.items():
        is_cbf = bool(np.all(np.asarray(g["filter"]) < 0))
        f = np.asarray(g["freq_hz"], float)
        if nav is not None:
            speed, c = nav
            sp = np.interp(g["time"], first["time"], speed)
            f = f * (1.0 + sp * np.cos(np.radians(g["cone_deg"])) / c)
        est[("CBF" if is_cbf else "KAL") + ("" if len(tracks) <= 2 else f" {name}")] = {
            "time": np.asarray(g["time"], float), "cone_deg": np.asarray(g["cone_deg"], float),
            "freq_hz": f}
    draw_nb_tracks(est, tr, out_png, title=Path(path).name)


draw = draw_nb_tracks  # the name scripts/reproduce_nb_ekf.py uses
