#!/usr/bin/env python
"""Build the cached TL tables in arrayproc/data/tl/ for the SPL paper's appendix environment and
compare the models.

Tables written:
  munk_bellhopcxx_incoherent.h5   bellhopcxx, 'IG' (the paper's model and mode), receiver depths
                                  0-1000 m every 10 m, ranges 0-50 km every 20 m
  munk_bellhopcxx_incoherent_dbperm.h5   the same with the appendix's printed 'CVM' option
                                  (bottom attenuation 0.8 dB/m instead of 0.8 dB/λ)
  munk_bellhop_fortran_incoherent_300m.h5  Fortran BELLHOP (same wheel), 'IG', 300 m only
  munk_bellhopcxx_semicoherent_300m.h5     bellhopcxx, 'SG' (Lloyd-mirror source pattern)
  munk_ram_band_300m.h5           RAM PE (pyram), converged grid, intensity averaged 45-55 Hz

The comparison (smoothed over ±500 m in range, receiver at 300 m, 1-30 km) goes to
``--json`` (default arrayproc/data/tl/tl_comparison.json).

Usage: python scripts/make_tl_tables.py [--out arrayproc/data/tl] [--json FILE] [--skip-ram]
       python scripts/make_tl_tables.py --plot DIR     (figures from the cached tables only)
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from arrayproc.acoustics.tl.bellhop import BellhopEnv, run_bellhop
from arrayproc.acoustics.tl.ram import RamEnv, ram_convergence, run_ram, run_ram_band
from arrayproc.acoustics.tl.table import TLTable

RCV = 300.0
SRC = 5.0


def at_depth(tab: TLTable, z: float, step_m: float = 20.0) -> TLTable:
    r = np.arange(0.0, tab.range_m[-1] + 0.5 * step_m, step_m)
    r = r[r <= tab.range_m[-1]]
    tl = tab(r, SRC, z)
    return TLTable(r, np.array([z]), np.array([SRC]), tl[None, None, :], dict(tab.attrs))


def smoothed(tab: TLTable, ranges: np.ndarray, half_window: float = 500.0) -> np.ndarray:
    r = np.arange(0.0, 50e3 + 1, 10.0)
    inten = 10.0 ** (-tab(r, SRC, RCV) / 10.0)
    return np.array([-10 * np.log10(inten[np.abs(r - x) <= half_window].mean()) for x in ranges])


def plot_tables(tl_dir: Path, out_dir: Path) -> None:
    """TL field of the main table (cf. SPL paper fig. 1) and the models at 300 m."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir.mkdir(parents=True, exist_ok=True)
    main_tab = TLTable.load(tl_dir / "munk_bellhopcxx_incoherent.h5")
    fig, ax = plt.subplots(figsize=(8, 4), constrained_layout=True)
    im = ax.pcolormesh(main_tab.range_m / 1e3, main_tab.rcv_depth_m, main_tab.tl_db[0],
                       vmin=50, vmax=100, cmap="jet_r", shading="auto")
    ax.invert_yaxis()
    ax.set_xlabel("range (km)")
    ax.set_ylabel("receiver depth (m)")
    ax.set_title("TL, SPL paper appendix environment, bellhopcxx incoherent, source 5 m, 50 Hz")
    fig.colorbar(im, ax=ax, label="TL (dB re 1 m)")
    fig.savefig(out_dir / "tl_field_bellhopcxx_incoherent.png", dpi=110)
    plt.close(fig)
    r = np.arange(0.0, 50e3 + 1, 20.0)
    fig, ax = plt.subplots(figsize=(8, 4), constrained_layout=True)
    for name, label in (("munk_bellhopcxx_incoherent", "bellhopcxx incoherent (paper's)"),
                        ("munk_bellhop_fortran_incoherent_300m", "Fortran BELLHOP incoherent"),
                        ("munk_bellhopcxx_incoherent_dbperm",
                         "bellhopcxx incoherent, bottom 0.8 dB/m ('CVM')"),
                        ("munk_bellhopcxx_semicoherent_300m", "bellhopcxx semi-coherent"),
                        ("munk_ram_band_300m", "RAM PE, 45-55 Hz average")):
        t = TLTable.load(tl_dir / f"{name}.h5")
        ax.plot(r / 1e3, t(r, SRC, RCV), lw=1.0, label=label)
    ax.set_xlabel("range (km)")
    ax.set_ylabel("TL (dB re 1 m)")
    ax.set_title("TL at 300 m receiver depth, source 5 m, 50 Hz")
    ax.set_ylim(100, 40)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    fig.savefig(out_dir / "tl_models_300m.png", dpi=110)
    plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "arrayproc" / "data"
                                         / "tl"))
    ap.add_argument("--json", default=None)
    ap.add_argument("--skip-ram", action="store_true")
    ap.add_argument("--plot", default=None, help="only draw figures from the cached tables")
    args = ap.parse_args()
    out = Path(args.out)
    if args.plot:
        plot_tables(out, Path(args.plot))
        return
    out.mkdir(parents=True, exist_ok=True)
    report: dict = {}

    t = time.perf_counter()
    cxx = run_bellhop(BellhopEnv(), "bellhopcxx")          # 10 m range grid, as the paper
    report["bellhopcxx_seconds"] = time.perf_counter() - t
    r20 = np.arange(0.0, 50e3 + 1, 20.0)
    main_tab = TLTable(r20, cxx.rcv_depth_m, cxx.src_depth_m,
                       cxx(r20[None, None, :], SRC, cxx.rcv_depth_m[None, :, None]),
                       dict(cxx.attrs, description="SPL paper appendix env, bellhopcxx IG"))
    main_tab.save(out / "munk_bellhopcxx_incoherent.h5")
    # interpolation error of the stored 20 m grid against the 10 m model grid at 300 m
    r10 = cxx.range_m[(cxx.range_m >= 1000) & (cxx.range_m <= 30000)]
    report["table_interp_err_db_max"] = float(np.max(np.abs(
        TLTable.load(out / "munk_bellhopcxx_incoherent.h5")(r10, SRC, RCV) - cxx(r10, SRC, RCV))))

    fort = run_bellhop(BellhopEnv(), "bellhop")
    at_depth(fort, RCV).save(out / "munk_bellhop_fortran_incoherent_300m.h5")
    semi = run_bellhop(BellhopEnv(run_type="SG"), "bellhopcxx")
    at_depth(semi, RCV).save(out / "munk_bellhopcxx_semicoherent_300m.h5")
    cvm = run_bellhop(BellhopEnv(ssp_option="CVM"), "bellhopcxx")   # the appendix as printed
    TLTable(r20, cvm.rcv_depth_m, cvm.src_depth_m,
            cvm(r20[None, None, :], SRC, cvm.rcv_depth_m[None, :, None]),
            dict(cvm.attrs, description="SPL paper appendix env as printed ('CVM': bottom "
                 "attenuation 0.8 dB/m), bellhopcxx IG")).save(
        out / "munk_bellhopcxx_incoherent_dbperm.h5")

    rr = np.arange(1000.0, 30001.0, 1000.0)
    raw = np.arange(1000.0, 30001.0, 10.0)
    report["ranges_m"] = rr.tolist()
    report["receiver_depth_m"] = RCV
    report["cxx_IG_smoothed"] = smoothed(cxx, rr).tolist()
    report["fortran_IG_smoothed"] = smoothed(fort, rr).tolist()
    report["cxx_SG_smoothed"] = smoothed(semi, rr).tolist()
    report["cxx_IG_dBperm_bottom_smoothed"] = smoothed(cvm, rr).tolist()
    report["max_abs_diff_cxx_vs_fortran_IG_raw_10m_db"] = float(
        np.max(np.abs(cxx(raw, SRC, RCV) - fort(raw, SRC, RCV))))
    report["max_abs_diff_IG_dBperlambda_vs_dBperm_db"] = float(
        np.max(np.abs(np.array(report["cxx_IG_smoothed"])
                      - np.array(report["cxx_IG_dBperm_bottom_smoothed"]))))
    if not args.skip_ram:
        grid = {"dz": 1.0, "dr": 20.0, "n_pade": 8}
        report["ram_grid"] = grid
        report["ram_convergence_db"] = ram_convergence(RamEnv(), 50.0, RCV, **grid)
        # pyram's own defaults (dz = λ/10, dr = 8 λ) against the converged grid, at 1 km
        lam = 1500.0 / 50.0
        rd, zd, tld = run_ram(RamEnv(), 50.0, RCV, dz=0.1 * lam, dr=8 * lam)
        rc, zc, tlc = run_ram(RamEnv(), 50.0, RCV, **grid)
        report["ram_default_grid_vs_converged_at_1km_db"] = float(abs(
            np.interp(1000.0, rd, tld[np.argmin(np.abs(zd - RCV))])
            - np.interp(1000.0, rc, tlc[np.argmin(np.abs(zc - RCV))])))
        t = time.perf_counter()
        ram = run_ram_band(RamEnv(), np.linspace(45.0, 55.0, 15), RCV, **grid)
        report["ram_band_seconds"] = time.perf_counter() - t
        at_depth(ram, RCV).save(out / "munk_ram_band_300m.h5")
        report["ram_band_smoothed"] = smoothed(ram, rr).tolist()
        report["max_abs_diff_ram_vs_cxx_SG_db"] = float(np.max(np.abs(
            np.array(report["ram_band_smoothed"]) - np.array(report["cxx_SG_smoothed"]))))
        report["max_abs_diff_ram_vs_cxx_IG_db"] = float(np.max(np.abs(
            np.array(report["ram_band_smoothed"]) - np.array(report["cxx_IG_smoothed"]))))
    js = Path(args.json) if args.json else out / "tl_comparison.json"
    js.write_text(json.dumps(report, indent=1))
    for k, v in report.items():
        if not isinstance(v, list):
            print(f"{k:48s} {v}")
    sizes = {p.name: p.stat().st_size for p in out.glob("*.h5")}
    print("table sizes (bytes):", sizes, "total", sum(sizes.values()))


if __name__ == "__main__":
    main()
