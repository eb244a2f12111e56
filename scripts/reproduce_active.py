"""Thesis ch. 4 from the active stages: resolutions (eqs. 4.3, 4.4), sidelobe plateau (4.5), the
wideband ambiguity surface (fig. 4.1), CFAR false-alarm rates and Pd, and the simulated active
scenario (detection, range and range-rate accuracy, absolute-Doppler classification, the
HFM -> BPSK bracket mode of 4.2.3).

    .venv/bin/python scripts/reproduce_active.py [--parts waveform,cfar,scenario]
        [--out DIR] [--json OUT] [--duration S] [--recording REC.h5] [--cfar-slow]
        [--beams START,STOP,COUNT] [--blank-direct] [--reuse]

waveform: the 4 s, 2047-bit, 1500 Hz BPSK through the stages' bank
(:mod:`arrayproc.stages.active.bank`): one noiseless echo, 3 dB widths in range rate and range
(eqs. 4.3, 4.4), the mean |chi|^2 over +-15 m/s and lags within T/4 (eq. 4.5), and
``ambiguity.png`` (fig. 4.1 analogue).

cfar: measured false-alarm rate of CA and OS (and GO, SO) on exponential noise against the
design pfa (1e-3, 1e-4; with ``--cfar-slow`` also 1e-5, 1e-6), Pd of a Swerling-1 target
against the closed form (CA, pfa 1e-6, N = 32), ``cfar_pd.png``.

scenario: ``data/scenarios/active_hfm_bpsk.toml`` (an HFM of the BPSK's band, then the 4 s
2047-bit BPSK 15 s later, every 30 s: one simulated recording whose /active carries both
replicas and the schedule; ``--duration`` lengthens it); the chain: ``active_beams`` (cone
sector ``--beams``, ``--blank-direct`` for its direct-blast gate) -> ``matched_filter`` ->
``cfar`` (full cube, every ping) and a second ``matched_filter`` in bracket mode around the
previous HFM ping's contacts -> ``cfar``. Contacts are associated with ``/truth/echoes``
(range within 30 m, cone within 10 deg; clutter also within two range cells and 3 deg).
Expected echo SNR after processing: echo level - noise spectral level + 10 log10 T + 10 log10
(elements) - 1.76 dB (Hann shading loss), with blanking + 10 log10 of the echo's fraction
received after the gate.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np

C = 1500.0
FS = 5120.0
KNOT = 1852.0 / 3600.0


def half_power_width(x: np.ndarray, y: np.ndarray) -> float:
    y = np.asarray(y, float) / np.max(y)
    k = int(np.argmax(y))
    lo, hi = k, k
    while lo > 0 and y[lo - 1] >= 0.5:
        lo -= 1
    while hi < y.size - 1 and y[hi + 1] >= 0.5:
        hi += 1
    xl = np.interp(0.5, [y[lo - 1], y[lo]], [x[lo - 1], x[lo]])
    xr = np.interp(0.5, [y[hi + 1], y[hi]], [x[hi + 1], x[hi]])
    return float(xr - xl)


def echo_plane(w, band, rates, delay=2.0, n_s=8.0):
    from arrayproc.stages.active import bank as bk
    n = int(n_s * FS)
    t = np.arange(n) / FS - delay
    x = w(t)
    plan = bk.band_plan(FS, n, band)
    X = np.fft.rfft(x, plan.n_fft)[plan.k0:plan.k0 + plan.n_bins].astype(np.complex64)
    bank = bk.replica_spectra(w.sample(FS), FS, plan.f0, plan.df, plan.n_bins,
                              bk.doppler_scale(rates, C))
    out = np.empty((rates.size, plan.n_bins), np.float32)
    bk.correlate(X, bank, out)
    return plan, X, bank, out


def range_width(plan, X, bank_row) -> float:
    z = np.fft.ifft(X * bank_row, plan.n_bins * 16)
    rng = np.arange(z.size) / (plan.fs_bb * 16) * C / 2
    return half_power_width(rng, np.abs(z) ** 2)


def part_waveform(out: Path) -> dict:
    from arrayproc.acoustics import waveforms as wfm
    from arrayproc.stages.active import bank as bk
    b = wfm.bpsk(1500.0, 4.0, 2047)
    B = b.bandwidth
    res = {"bandwidth_hz": B}
    rates = np.linspace(-0.3, 0.3, 241)
    plan, X, bank, p = echo_plane(b, (1500 - B, 1500 + B), rates)
    d, r = np.unravel_index(np.argmax(p), p.shape)
    dv = half_power_width(rates, p[:, r])
    res["doppler_resolution"] = {
        "measured_mps": dv, "two_way_0.886c/(2fcT)": bk.doppler_resolution(1500, 4, C),
        "eq_4_3_as_printed_0.886c/(fcT)": 0.886 * C / (1500 * 4),
        "ratio_to_two_way": dv / bk.doppler_resolution(1500, 4, C)}
    widths = {}
    for name, h in (("main_lobe_fc+-B", 1.0), ("band_fc+-0.75B", 0.75),
                    ("3dB_band_fc+-B/2", 0.5)):
        pl, Xh, bh, _ = echo_plane(b, (1500 - h * B, 1500 + h * B), np.zeros(1))
        widths[name] = range_width(pl, Xh, bh[0])
    h = wfm.hfm(1500 - B / 2, 1500 + B / 2, 4.0)
    pl, Xh, bh, _ = echo_plane(h, (1500 - B / 2, 1500 + B / 2), np.zeros(1))
    widths["hfm_same_band"] = range_width(pl, Xh, bh[0])
    ref = bk.range_resolution(B, C)
    res["range_resolution"] = {"eq_4_4_m": ref, "measured_m": widths,
                               "ratio": {k: v / ref for k, v in widths.items()}}
    rr = bk.range_rate_grid(None, 1500.0, 4.0, C, False)
    band = (1500 - 1.05 * B, 1500 + 1.05 * B)
    plan, X, bank, p = echo_plane(b, band, rr)
    p = p / p.max()
    lag = np.arange(plan.n_bins) / plan.fs_bb - 2.0
    levels = {}
    for lo, hi in ((0.02, 1.0), (0.02, 0.5), (0.02, 2.0), (0.02, 4.0)):
        sel = (np.abs(lag) > lo) & (np.abs(lag) < hi)
        levels[f"lags_{lo}-{hi}s"] = float(10 * np.log10(p[:, sel].mean()))
    res["sidelobe_plateau"] = {"eq_4_5_db": bk.sidelobe_level_db(2047),
                               "measured_db": levels,
                               "channels": int(rr.size)}
    # fig. 4.1: ambiguity surface, +-15 m/s, +-0.5 s of lag (+-375 m)
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    keep = np.abs(lag) <= 0.5
    fig, ax = plt.subplots(figsize=(7.5, 5.0), dpi=110)
    im = ax.imshow(10 * np.log10(np.maximum(p[:, keep], 1e-12)), aspect="auto", origin="lower",
                   extent=[lag[keep][0] * C / 2, lag[keep][-1] * C / 2, rr[0], rr[-1]],
                   vmin=-50, vmax=0, cmap="viridis", interpolation="nearest")
    fig.colorbar(im, ax=ax, pad=0.02).set_label("|χ|², dB re peak (50 dB range)")
    ax.set_xlabel("range offset (m)")
    ax.set_ylabel("range rate (m/s, positive opening)")
    ax.set_title("wideband ambiguity of the 4 s, 2047-bit, 1500 Hz BPSK (thesis fig. 4.1)\n"
                 f"through the matched_filter bank: {rr.size} channels", fontsize=10)
    fig.tight_layout()
    fig.savefig(out / "ambiguity.png")
    plt.close(fig)
    return res


def part_cfar(out: Path, slow: bool) -> dict:
    from arrayproc.stages.active import cfar as cf
    res = {"false_alarms": [], "pd": []}
    pfas = [1e-3, 1e-4] + ([1e-5, 1e-6] if slow else [])
    for method in ("ca", "os", "go", "so"):
        for pfa in pfas if method in ("ca", "os") else pfas[:2]:
            cfg = cf.CfarConfig(method, pfa, (2, 0), (16, 0))
            rng = np.random.default_rng(int(1e6 * pfa) + len(method))
            n_target = int(100 / pfa)
            cols = 4000
            tested = alarms = 0
            while tested < n_target:
                rows = max(1, min(2000, (n_target - tested) // cols + 1))
                p = rng.standard_exponential((rows, cols), dtype=np.float32)
                det = cf.detect(p, cfg, r0=18, r1=cols - 18)
                alarms += det.rows.size
                tested += rows * (cols - 36)
            res["false_alarms"].append({"method": method, "pfa": pfa, "cells": tested,
                                        "alarms": alarms, "rate": alarms / tested,
                                        "ratio": alarms / tested / pfa})
            print(f"  cfar {method} pfa {pfa:g}: {alarms} alarms in {tested:.3g} cells, "
                  f"ratio {alarms / tested / pfa:.2f}", flush=True)
    cfg = cf.CfarConfig("ca", 1e-6, (2, 0), (16, 0))
    a = cf.alpha_ca(1e-6, 32)
    rng = np.random.default_rng(9)
    snrs = np.arange(8.0, 27.0, 1.0)
    for s_db in snrs:
        s = 10 ** (s_db / 10)
        p = rng.standard_exponential((500, 2000), dtype=np.float32)
        cols = np.arange(40, 1960, 40)
        p[:, cols] = rng.exponential(1 + s, (500, cols.size))
        det = cf.detect(p, cfg)
        pd = np.isin(det.cols, cols).sum() / (500 * cols.size)
        res["pd"].append({"snr_db": float(s_db), "pd": float(pd),
                          "closed_form": float(cf.pd_ca_swerling1(a, 32, s))})
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 4), dpi=110)
    ax.plot(snrs, [r["closed_form"] for r in res["pd"]], "k-", label="closed form")
    ax.plot(snrs, [r["pd"] for r in res["pd"]], "o", label="measured (24 500 trials/point)")
    ax.set_xlabel("mean SNR per cell (dB), Swerling 1")
    ax.set_ylabel("probability of detection")
    ax.set_title("CA-CFAR, N = 32, pfa 1e-6", fontsize=10)
    ax.grid(True, alpha=0.4)
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "cfar_pd.png")
    plt.close(fig)
    return res


def simulate_schedule(out: Path, duration: float | None) -> Path:
    """``data/scenarios/active_hfm_bpsk.toml`` (HFM, then the BPSK 15 s later, every 30 s: one
    recording with both replicas and the schedule in /active), optionally lengthened."""
    from importlib.resources import files

    from arrayproc.config import parse_toml
    from arrayproc.sim.run import simulate
    from arrayproc.sim.scenario import parse_scenario
    text = files("arrayproc.data").joinpath("scenarios/active_hfm_bpsk.toml").read_text()
    base = parse_toml(text, "active_hfm_bpsk.toml")
    if duration:
        base["recording"]["duration"] = float(duration)
    path = out / "active_hfm_bpsk.h5"
    if not path.exists():
        simulate(parse_scenario(base, "active_hfm_bpsk.toml"), path)
    return path


CHAIN = """
[input]
block = 16384
[[stage]]
type = "active_beams"
name = "beams"
beams = {{ start = {b0}, stop = {b1}, count = {nb} }}
blank_direct = {blank}
[[stage]]
type = "matched_filter"
name = "mf"
[[stage]]
type = "cfar"
name = "contacts"
pfa = 1e-6
min_range_m = 150.0
[[stage]]
type = "matched_filter"
name = "mf_bracket"
input = "beams"
bracket = {{ source = "contacts", range_m = {range_m}, cone_deg = {cone_deg} }}
[[stage]]
type = "cfar"
name = "contacts_bracket"
pfa = 1e-6
min_range_m = 150.0
"""


def part_scenario(out: Path, rec_path: Path | None, duration: float | None,
                  range_m: float, cone_deg: float, reuse: bool = False,
                  beams: tuple[float, float, int] = (0.0, 180.0, 181),
                  blank: str = "") -> dict:
    """Simulate (or reuse) the recording, run the chain, score the contacts
    (:func:`arrayproc.evaluate.scenarios.thesis_active.score_products`) and plot them."""
    from arrayproc.chain import build_chain, run_chain
    from arrayproc.evaluate.scenarios.thesis_active import score_products
    from arrayproc.io.products import ProductsWriter
    from arrayproc.io.recording import Recording
    from arrayproc.stages import load_all
    load_all()
    t0 = time.perf_counter()
    c_sim0 = time.process_time()
    rec_path = rec_path or simulate_schedule(out, duration)
    t_sim, c_sim = time.perf_counter() - t0, time.process_time() - c_sim0
    # blank: "" (no gate), "all" (every ping) or comma-separated waveform names/kinds
    sfx = "" if not blank else ("_blank" if blank == "all" else "_blank_" + blank.replace(",",
                                                                                          "_"))
    prod = out / f"active_products{sfx}.h5"
    blank_key = ("false" if not blank else "true" if blank == "all"
                 else "[" + ", ".join(f'"{x}"' for x in blank.split(",")) + "]")
    spec = build_chain(CHAIN.format(range_m=range_m, cone_deg=cone_deg, b0=beams[0],
                                    b1=beams[1], nb=int(beams[2]), blank=blank_key))
    t0 = time.perf_counter()
    c0 = time.process_time()
    if not (reuse and prod.exists()):
        with Recording(rec_path) as rec, ProductsWriter(prod, source=str(rec_path)) as w:
            run_chain(rec, spec, w)
    t_proc, c_proc = time.perf_counter() - t0, time.process_time() - c0
    res = {"recording": str(rec_path), "simulate_s": t_sim, "simulate_cpu_s": c_sim,
           "process_wall_s": t_proc, "process_cpu_s": c_proc, "products": str(prod),
           "beams": list(beams), "blank_direct": blank_key, "loadavg": os.getloadavg()}
    res.update(score_products(rec_path, prod, beams, blank, range_m, cone_deg))
    for row in res["submarine"]:
        print(f"  ping {row['ping']}: {row}", flush=True)
    from arrayproc.plots.contacts import plot_contacts
    plot_contacts(str(prod), str(out / f"contacts{sfx}.png"))
    return res


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--parts", default="waveform,cfar,scenario")
    ap.add_argument("--out", default="active_out")
    ap.add_argument("--json", default=None)
    ap.add_argument("--duration", type=float, default=None, help="scenario duration, s")
    ap.add_argument("--recording", default=None, help="use this alternating recording")
    ap.add_argument("--bracket-range", type=float, default=200.0)
    ap.add_argument("--bracket-cone", type=float, default=5.0)
    ap.add_argument("--cfar-slow", action="store_true")
    ap.add_argument("--beams", default="0,180,181",
                    help="scenario: cone angles start,stop,count of active_beams (deg)")
    ap.add_argument("--blank-direct", nargs="?", const="all", default="",
                    help="scenario: active_beams blank_direct: every ping (no value) or the "
                    "comma-separated waveform names/kinds given (e.g. bpsk)")
    ap.add_argument("--reuse", action="store_true",
                    help="scenario: reuse OUT's recording and products when present")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    parts = args.parts.split(",")
    b = args.beams.split(",")
    beams = (float(b[0]), float(b[1]), int(b[2]))
    res = {}
    if "waveform" in parts:
        res["waveform"] = part_waveform(out)
        print(json.dumps(res["waveform"], indent=1), flush=True)
    if "cfar" in parts:
        res["cfar"] = part_cfar(out, args.cfar_slow)
        print(json.dumps(res["cfar"]["pd"][::3], indent=1), flush=True)
    if "scenario" in parts:
        res["scenario"] = part_scenario(out, Path(args.recording) if args.recording else None,
                                        args.duration, args.bracket_range, args.bracket_cone,
                                        args.reuse, beams, args.blank_direct)
        print(json.dumps({k: v for k, v in res["scenario"].items() if k != "submarine"},
                         indent=1), flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(res, indent=2, default=float))


if __name__ == "__main__":
    main()
