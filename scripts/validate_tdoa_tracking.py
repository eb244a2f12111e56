"""Validation of the recursive TDOA tracker (thesis 3.2.2.2, eqs. 3.37-3.40) against
the batch TD-TMA (thesis 3.3.2, eqs. 3.48-3.52) on the same delays.

The thesis's case: a 20 m towed array (``scripts/data/tdoa_20m_scenario.toml``: 21
hydrophones 1 m apart, ownship 3 m/s, 0° then a 45° turn to port at 300 s) and a static
broadband source placed 2, 5 and 10 km from the ownship's position at t = 150 s, 70° off the
first leg's bow. For each range the script runs, as separate commands,

    arrayproc simulate SCENARIO.toml -o rec.h5
    arrayproc process rec.h5 -c scripts/data/tdoa_20m_tde.toml -o del.h5
    arrayproc track del.h5 -c arrayproc/data/trackers/tdoa_static.toml -o trk.h5
    arrayproc track del.h5 -c arrayproc/data/trackers/tdoa_cv.toml -o trk_cv.h5
    arrayproc tma del.h5 -c arrayproc/data/tma/delays.toml -o tma.h5

then, in this process, the batch TD-TMA of the growing windows [t_0, t_k] (what ``tma`` does
for one window, every ``--batch-every`` s) for the batch's range error against time, and the
Cramér-Rao bounds at the truth: the static-position bound of all delays up to t_k (the
tracker's model, thesis eq. (C.8) summed over snapshots) and the constant-velocity bound of
the batch's model (eq. (3.53)), both with the delays' σ from the product and the covariance of
delays against one reference channel. Range = distance from the reference hydrophone.

    .venv/bin/python scripts/validate_tdoa_tracking.py --out /tmp/tdoa [--ranges 2000 5000 10000]

Writes ``tdoa_range_error.png`` and ``summary.json`` in ``--out`` and prints the table.
"""

from __future__ import annotations

import argparse
import json
import math
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "scripts/data/tdoa_20m_scenario.toml"
CHAIN = ROOT / "scripts/data/tdoa_20m_tde.toml"
TRACKERS = {"static": ROOT / "arrayproc/data/trackers/tdoa_static.toml",
            "cv": ROOT / "arrayproc/data/trackers/tdoa_cv.toml"}
TMA = ROOT / "arrayproc/data/tma/delays.toml"
CLI = str(Path(sys.executable).with_name("arrayproc"))
T_REF, OFF_BOW_DEG = 150.0, 70.0      # the source's placement: from the ownship at T_REF


def _run(args: list[str]) -> None:
    print("$", " ".join(str(a) for a in args), flush=True)
    subprocess.run([CLI, *map(str, args)], check=True)


def scenario(range_m: float, out: Path) -> Path:
    """The bundled scenario with the source ``range_m`` from the ownship at ``T_REF``."""
    text = SCENARIO.read_text()
    own = np.array([0.0, 3.0 * T_REF])                      # first leg: course 0°, 3 m/s
    b = math.radians(OFF_BOW_DEG)
    s = own + range_m * np.array([math.sin(b), math.cos(b)])
    old = "start = [4698.5, 2160.1]"
    assert old in text
    p = out / f"scenario_{int(range_m)}.toml"
    p.write_text(text.replace(old, f"start = [{s[0]:.1f}, {s[1]:.1f}]"))
    return p


def crlb_curves(t: np.ndarray, el: np.ndarray, src: np.ndarray, sig: np.ndarray, ref: int,
                c: float) -> tuple[np.ndarray, np.ndarray]:
    """Range σ (m) at each t_k of the static-position bound and of the CV bound (state at
    t_0, position propagated to t_k), from the delays of rows 0..k."""
    from arrayproc.geo.tdoa import jacobian, reference_covariance
    from arrayproc.track.batch.fim import range_sigma

    n = t.size
    F2 = np.zeros((2, 2))
    F4 = np.zeros((4, 4))
    s_static = np.full(n, np.nan)
    s_cv = np.full(n, np.nan)
    for k in range(n):
        ok = np.isfinite(sig[k]) & (sig[k] > 0)
        ok[ref] = False
        if ok.sum() >= 2:
            keep = np.flatnonzero(ok | (np.arange(ok.size) == ref))
            r = int(np.searchsorted(keep, ref))
            H = np.delete(jacobian(np.r_[src, 0.0], np.c_[el[k, keep, :2],
                                                           np.zeros(keep.size)], r, c),
                          r, axis=0)[:, :2]
            Ci = np.linalg.inv(reference_covariance(sig[k, ok]))
            F2 += H.T @ Ci @ H
            J = np.hstack([H, (t[k] - t[0]) * H])             # ∂τ/∂[x0, y0, vx, vy]
            F4 += J.T @ Ci @ J
        rel = src - el[k, ref, :2]
        if np.linalg.cond(F2) < 1e14:
            s_static[k] = float(range_sigma(rel, np.linalg.inv(F2)))
        if np.linalg.cond(F4) < 1e14:
            C4 = np.linalg.inv(F4)
            G = np.hstack([np.eye(2), (t[k] - t[0]) * np.eye(2)])
            s_cv[k] = float(range_sigma(rel, G @ C4 @ G.T))
    return s_static, s_cv


def batch_curve(del_path: Path, rec_path: Path, every: float
                ) -> tuple[np.ndarray, np.ndarray, list]:
    """The batch TD-TMA (``tma`` with data/tma/delays.toml) on the growing windows
    [t_0, t_k], t_k every ``every`` s and the last row: times, positions at t_k (k, 2), and
    the solutions."""
    from arrayproc.io.recording import Recording
    from arrayproc.track.batch.run import load_tma_config, read_measurements, solve_window

    cfg = load_tma_config(str(TMA))
    meas = read_measurements(str(del_path), cfg)
    t = meas["time"]
    marks = np.arange(t[0] + every, t[-1], every)
    ends = sorted(set(t[np.searchsorted(t, marks)].tolist()) | {float(t[-1])})
    pos, sols = [], []
    with Recording(str(rec_path)) as rec:
        for tk in ends:
            sol = solve_window(meas, rec, cfg, float(t[0]), float(tk))
            x = sol.state
            pos.append(x[:2] + (tk - sol.t0) * x[2:])
            sols.append(sol)
    return np.array(ends), np.array(pos), sols


def one_range(range_m: float, out: Path, every: float) -> dict:
    """Simulate, estimate delays, track, batch-solve one range; the curves and numbers."""
    import h5py

    from arrayproc.io.products import read_products
    from arrayproc.io.recording import Recording
    from arrayproc.track.delays import read_delays

    tag = f"{int(range_m)}"
    rec, dels = out / f"rec_{tag}.h5", out / f"del_{tag}.h5"
    trk = {m: out / f"trk_{m}_{tag}.h5" for m in TRACKERS}
    tma = out / f"tma_{tag}.h5"
    _run(["simulate", scenario(range_m, out), "-o", rec])
    _run(["process", rec, "-c", CHAIN, "-o", dels])
    for m, cfg in TRACKERS.items():
        _run(["track", dels, "-c", cfg, "-o", trk[m], "--no-progress"])
    _run(["tma", dels, "-c", TMA, "-o", tma])
    with h5py.File(rec, "r") as f:
        src = np.asarray(f["truth/sources/target/position"][0], float)[:2]
    m = read_delays(str(dels))
    from arrayproc.track.batch.motion import nav_velocity

    with Recording(str(rec)) as r:
        poses = r.poses(m["time"])
        c = float(r.sound_speed)
        vel = nav_velocity(r.nav, m["time"])
    el = np.stack([p.elements for p in poses])
    ref = m["reference"]
    own = el[:, ref, :2]
    true_r = np.hypot(*(src - own).T)
    res: dict = {"range_m": range_m, "source": src.tolist(),
                 "sigma_delay_median_s": float(np.nanmedian(m["sigma"][:, 1:])),
                 "corr_median": float(np.nanmedian(m["corr"][:, 1:])),
                 "n_rows": int(m["time"].size), "time": m["time"].tolist(),
                 "true_range": true_r.tolist()}
    for name, path in trk.items():
        g = read_products(str(path))["tracks"]
        tt = np.asarray(g["time"])
        k = np.searchsorted(m["time"], tt)
        est_r = np.hypot(g["x"] - own[k, 0], g["y"] - own[k, 1])
        P = np.asarray(g["cov"])[:, :2, :2]
        rel = np.c_[g["x"] - own[k, 0], g["y"] - own[k, 1]]
        u = rel / np.hypot(*rel.T)[:, None]
        res[f"track_{name}"] = {
            "time": tt.tolist(), "range_error": (est_r - true_r[k]).tolist(),
            "pos_error": np.hypot(g["x"] - src[0], g["y"] - src[1]).tolist(),
            "range_sigma": np.sqrt(np.einsum("bi,bij,bj->b", u, P, u)).tolist(),
            "side_weight": np.asarray(g["side_weight"]).tolist()}
    # every Gaussian filter on the same delays with the static tracker's settings (in process),
    # and the UKF without the array-motion correction
    from arrayproc.track.delays import GAUSSIAN_FILTERS, load_delays_config, track_delays

    cfg = load_delays_config(str(TRACKERS["static"]))
    res["filters_static"] = {}
    for fname in GAUSSIAN_FILTERS:
        c0 = time.process_time()
        tr = track_delays(m["time"], m["tau"], m["sigma"], el, ref, c, cfg["delays"], fname,
                          {} if fname != cfg["filter"] else cfg["params"],
                          heading_rad=np.deg2rad([p.heading for p in poses]), corr=m["corr"],
                          array_velocity=vel if cfg["delays"]["array_motion"] else None)
        cpu = time.process_time() - c0
        rr = np.hypot(*tr["rel"][-1])
        u = tr["rel"][-1] / rr
        res["filters_static"][fname] = {
            "range_error": float(rr - true_r[-1]),
            "pos_error": float(np.hypot(tr["x"][-1] - src[0], tr["y"][-1] - src[1])),
            "range_sigma": float(np.sqrt(u @ tr["P"][-1] @ u)), "cpu_s": cpu}
    tr = track_delays(m["time"], m["tau"], m["sigma"], el, ref, c, cfg["delays"], cfg["filter"],
                      cfg["params"], heading_rad=np.deg2rad([p.heading for p in poses]),
                      corr=m["corr"])
    res["static_no_motion_correction"] = {
        "range_error": float(np.hypot(*tr["rel"][-1]) - true_r[-1]),
        "range_error_curve": (np.hypot(*tr["rel"].T) - true_r[tr["row"]]).tolist()}
    cpu0 = time.process_time()
    tb, pos, sols = batch_curve(dels, rec, every)
    cpu_batch = time.process_time() - cpu0
    kb = np.searchsorted(m["time"], tb)
    rb = np.hypot(pos[:, 0] - own[kb, 0], pos[:, 1] - own[kb, 1])
    g = read_products(str(tma))["tma"]
    xt = np.array([g["x"][0], g["y"][0], g["vx"][0], g["vy"][0]])
    cli_end = xt[:2] + (float(g["t1"][0]) - float(g["t0"][0])) * xt[2:]
    res["batch"] = {"time": tb.tolist(), "range_error": (rb - true_r[kb]).tolist(),
                    "pos_error": np.hypot(pos[:, 0] - src[0], pos[:, 1] - src[1]).tolist(),
                    "velocity": [s.state[2:].tolist() for s in sols],
                    "reported_range_sigma_t0": [float(s.range_sigma) for s in sols],
                    "cpu_s": cpu_batch, "side": [s.side for s in sols]}
    res["tma_cli"] = {"state_t0": xt.tolist(),
                      "end_pos_error": float(np.hypot(*(cli_end - src))),
                      "end_range_error": float(np.hypot(*(cli_end - own[-1])) - true_r[-1]),
                      "same_as_last_window": bool(np.allclose(cli_end, pos[-1], atol=1e-3))}
    sig = np.where(np.isfinite(m["sigma"]), m["sigma"], np.nan)
    s_st, s_cv = crlb_curves(m["time"], el, src, sig, ref, c)
    res["crlb_static_range_sigma"] = s_st.tolist()
    res["crlb_cv_range_sigma"] = s_cv.tolist()
    return res


def plot(results: list[dict], path: Path) -> None:
    """|Range error| against time (log scale: the errors span 0.1 m to kilometres): the
    trackers, the batch on growing windows, and the CRLB σ of both models."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(results), 1, figsize=(9, 3.6 * len(results)), sharex=True)
    axes = np.atleast_1d(axes)
    for ax, r in zip(axes, results, strict=True):
        t = np.array(r["time"])
        for name, col in (("static", "C0"), ("cv", "C2")):
            tr = r[f"track_{name}"]
            ax.semilogy(tr["time"], np.abs(tr["range_error"]), color=col, lw=1.3,
                        label=f"tracker (UKF, {name} model)")
        nm = r["static_no_motion_correction"]["range_error_curve"]
        ax.semilogy(r["track_static"]["time"], np.abs(nm), color="C0", lw=0.8, alpha=0.45,
                    ls="--", label="tracker (static), no array-motion correction")
        b = r["batch"]
        ax.semilogy(b["time"], np.abs(b["range_error"]), "o", color="C3", ms=5,
                    label="batch TD-TMA (CV) on [t₀, t]")
        ax.semilogy(t, r["crlb_static_range_sigma"], "k--", lw=0.9, label="CRLB σ, static model")
        ax.semilogy(t, r["crlb_cv_range_sigma"], "k:", lw=1.1, label="CRLB σ, CV model")
        ax.axvline(300.0, color="0.6", lw=0.8)
        ax.set_ylim(0.03, 1e6)
        ax.set_ylabel("|range error| (m)")
        ax.set_title(f"static source at {r['range_m'] / 1000:g} km (median delay σ "
                     f"{r['sigma_delay_median_s'] * 1e6:.1f} µs); ownship turn at 300 s "
                     "(grey line)", fontsize=10)
        ax.grid(alpha=0.3, which="both")
    axes[0].legend(fontsize=8, ncol=2, loc="upper right")
    axes[-1].set_xlabel("time (s)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True, help="working directory for files and results")
    ap.add_argument("--ranges", nargs="+", type=float, default=[2000.0, 5000.0, 10000.0])
    ap.add_argument("--batch-every", type=float, default=60.0,
                    help="s between the growing batch windows' ends")
    a = ap.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    results = [one_range(r, out, a.batch_every) for r in a.ranges]
    plot(results, out / "tdoa_range_error.png")
    (out / "summary.json").write_text(json.dumps(results))
    print("\nrange | delay σ | tracker static: range err, pos err, σ_r | tracker cv: range err,"
          " pos err | batch (tma): range err, pos err | CRLB σ_r static, cv (final)")
    for r in results:
        s, v, b = r["track_static"], r["track_cv"], r["batch"]
        print(f"{r['range_m']:6.0f} m | {r['sigma_delay_median_s'] * 1e6:5.1f} µs | "
              f"{s['range_error'][-1]:8.1f} {s['pos_error'][-1]:8.1f} {s['range_sigma'][-1]:7.1f}"
              f" | {v['range_error'][-1]:8.1f} {v['pos_error'][-1]:8.1f} | "
              f"{b['range_error'][-1]:8.1f} {b['pos_error'][-1]:8.1f} | "
              f"{r['crlb_static_range_sigma'][-1]:7.1f} {r['crlb_cv_range_sigma'][-1]:7.1f}")
        print(f"        tma CLI end: range err {r['tma_cli']['end_range_error']:.1f} m, pos err "
              f"{r['tma_cli']['end_pos_error']:.1f} m, same as last window: "
              f"{r['tma_cli']['same_as_last_window']}; batch CPU {b['cpu_s']:.1f} s")
        print("        static UKF without the array-motion correction: final range err "
              f"{r['static_no_motion_correction']['range_error']:.1f} m")
        print("        static model, final range err / σ_r / CPU per filter: " + ", ".join(
            f"{k} {v['range_error']:.1f} m / {v['range_sigma']:.1f} m / {v['cpu_s']:.2f} s"
            for k, v in r["filters_static"].items()))
    ru = resource.getrusage(resource.RUSAGE_SELF)
    print(f"this process: {ru.ru_utime + ru.ru_stime:.1f} s CPU")


if __name__ == "__main__":
    main()
