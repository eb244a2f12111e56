"""The active scenario: the multi-target tracker (``measurements = "contacts"``)
on the contacts of the active chain, scored against the simulator's /truth.

Runs (each step skipped with ``--reuse`` when its output exists)::

    arrayproc simulate data/scenarios/active_bpsk_long.toml -o OUT/rec.h5
    arrayproc process OUT/rec.h5 -c OUT/chain.toml -o OUT/prod.h5
    arrayproc track OUT/prod.h5 -c data/trackers/active_contacts.toml -o OUT/tracks.h5

``OUT/chain.toml`` is ``data/chains/active.toml`` with the range-rate channels limited to
±``--rr-max`` m/s (the ownship's 3.1 m/s plus the targets') and no range-Doppler maps; the
shipped ±15 m/s bank costs about twice the CPU.

Reported (scored by :mod:`arrayproc.evaluate.scenarios.active_tracking`): contacts —
the submarine's echo detected per ping (range within 30 m, one of the
two candidate bearings within 3° of the truth), clutter echoes detected and flagged moving,
false alarms (contacts within 60 m and 5° of no echo), and how many of each pass the
tracker's input filter (``moving_only``, ``min_snr_db``); tracks — the share of the pings with a
submarine contact during which its principal confirmed track holds it (within ``--gate`` m),
breaks, position / velocity / range-rate errors of that track, and every other confirmed
track with its class (the submarine's port/starboard mirror image, a clutter scatterer or
its image, or noise false alarms), its confirmed life in pings and its hits; GOSPA against
the submarine. Figures: the tracks over the truth, and the submarine track's errors.

    .venv/bin/python scripts/validate_active_tracking.py --out OUT --json OUT/active.json \\
        --plot docs/figures/multi_target/active_tracks.png \\
        --plot-errors docs/figures/multi_target/active_errors.png
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from arrayproc.evaluate.scenarios.active_tracking import evaluate
from arrayproc.io.products import read_products

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "arrayproc" / "data"


def _cpu_children() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _run(cmd: list[str]) -> dict:
    c0, w0 = _cpu_children(), time.perf_counter()
    print("$", " ".join(cmd), flush=True)
    subprocess.run(cmd, check=True)
    return {"cmd": " ".join(cmd), "cpu_s": round(_cpu_children() - c0, 1),
            "wall_s": round(time.perf_counter() - w0, 1)}


def chain_variant(path: Path, rr_max: float) -> None:
    """Write data/chains/active.toml with range rates ±rr_max m/s and no range-Doppler maps."""
    s = (DATA / "chains" / "active.toml").read_text(encoding="utf-8")
    old = "range_rate = { min = -15.0, max = 15.0 }"
    if old not in s:
        raise SystemExit("active.toml: the range_rate line changed; update chain_variant")
    s = s.replace(old, f"range_rate = {{ min = {-rr_max}, max = {rr_max} }}")
    lines = [ln for ln in s.splitlines() if not ln.startswith("range_doppler")]
    path.write_text(f"# data/chains/active.toml with range rates within ±{rr_max} m/s and no "
                    "range-Doppler maps (scripts/validate_active_tracking.py)\n"
                    + "\n".join(lines) + "\n", encoding="utf-8")


COLORS = {"submarine": "tab:blue", "submarine_mirror": "tab:orange",
          "clutter": "tab:brown", "clutter_mirror": "tab:pink", "false_alarms": "tab:purple"}


def plot_tracks(p: dict, path: str) -> None:
    """Map of the confirmed tracks over the truth, and each confirmed track's life."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax, bx) = plt.subplots(1, 2, figsize=(14, 6.5),
                                 gridspec_kw={"width_ratios": [1.25, 1]})
    own, sub = p["own"], p["sub"]
    ax.plot(own["position"][:, 0] / 1e3, own["position"][:, 1] / 1e3, "k-", lw=1.5,
            label="ownship")
    ax.plot(sub["position"][:, 0] / 1e3, sub["position"][:, 1] / 1e3, "r-", lw=4, alpha=0.35,
            label="submarine (truth)")
    ax.plot(p["clutter"][:, 0] / 1e3, p["clutter"][:, 1] / 1e3, "x", color="0.5", ms=5,
            label="still clutter (truth)")
    cls = {o["track_id"]: o["class"] for o in p["others"]}
    cls[p["principal"]] = "submarine"
    shown = set()
    lanes = sorted(cls, key=lambda i: (i != p["principal"], i))
    for lane, i in enumerate(lanes):
        m = p["conf"] & (p["tid"] == i)
        col = COLORS[cls[i]]
        lab = None if cls[i] in shown else f"confirmed track: {cls[i].replace('_', ' ')}"
        shown.add(cls[i])
        ax.plot(p["xy"][m, 0] / 1e3, p["xy"][m, 1] / 1e3, "o-", color=col, ms=3, lw=1.2,
                label=lab)
        ax.annotate(str(i), (p["xy"][m, 0][-1] / 1e3, p["xy"][m, 1][-1] / 1e3), fontsize=8,
                    color=col, xytext=(3, 3), textcoords="offset points")
        tm = p["tt"][m] / 60.0
        hit = p["row"][m] >= 0
        bx.plot(tm, np.full(tm.size, lane), "-", color=col, lw=2)
        bx.plot(tm[hit], np.full(hit.sum(), lane), "o", color=col, ms=4)
        bx.plot(tm[~hit], np.full((~hit).sum(), lane), "o", mfc="white", color=col, ms=4)
    ax.set_xlabel("east (km)")
    ax.set_ylabel("north (km)")
    ax.set_aspect("equal")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    ax.set_title("confirmed tracks over the truth (id at the last point)")
    bx.set_yticks(range(len(lanes)))
    bx.set_yticklabels([str(i) for i in lanes], fontsize=7)
    bx.set_xlabel("time (min)")
    bx.set_ylabel("track id")
    bx.set_xlim(0, p["ping_t"][-1] / 60.0 + 0.5)
    bx.grid(alpha=0.3)
    bx.set_title("confirmed life per track (filled: contact, open: coasted)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_errors(p: dict, path: str) -> None:
    """The submarine track's position and range-rate errors, and GOSPA, per ping."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    pr = p["principal"]
    m = p["conf"] & (p["tid"] == pr)
    t = p["tt"][m]
    sxy, sv = p["sub_at"](t)
    oxy, ov, _h = p["own_at"](t)
    los = sxy - oxy
    u = los / np.linalg.norm(los, axis=1, keepdims=True)
    err = np.linalg.norm(p["xy"][m] - sxy, axis=1)
    rng_err = np.sum(u * (p["xy"][m] - sxy), 1)
    fig, axs = plt.subplots(3, 1, figsize=(8, 8), sharex=True)
    axs[0].plot(t / 60, err, "o-", label="|position error|")
    axs[0].plot(t / 60, rng_err, "s--", ms=3, label="along the line of sight")
    axs[0].set_ylabel("error (m)")
    axs[0].legend(fontsize=8)
    vt = p["_vel"][m]
    rr_err = np.sum(u * (vt - ov), 1) - np.sum(u * (sv - ov), 1)
    axs[1].plot(t / 60, rr_err, "o-", label="range rate")
    axs[1].plot(t / 60, np.linalg.norm(vt - sv, axis=1), "s--", ms=3, label="|velocity error|")
    axs[1].set_ylabel("error (m/s)")
    axs[1].legend(fontsize=8)
    axs[2].plot(p["ping_t"] / 60, p["gospa"], "o-")
    axs[2].set_ylabel("GOSPA vs submarine (m)")
    axs[2].set_xlabel("time (min)")
    for a in axs:
        a.grid(alpha=0.3)
    axs[0].set_title(f"submarine track {pr}: errors against the truth per ping")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True, help="working directory")
    ap.add_argument("--scenario", default=str(DATA / "scenarios" / "active_bpsk_long.toml"))
    ap.add_argument("--tracker", default=str(DATA / "trackers" / "active_contacts.toml"))
    ap.add_argument("--rr-max", type=float, default=8.0, help="range-rate bank, ±m/s")
    ap.add_argument("--gate", type=float, default=300.0,
                    help="m: a track within this of the truth holds it")
    ap.add_argument("--cutoff", type=float, default=500.0, help="GOSPA cut-off, m")
    ap.add_argument("--reuse", action="store_true", help="keep existing rec/prod/tracks")
    ap.add_argument("--tracks-name", default="tracks.h5", help="tracks file inside --out")
    ap.add_argument("--json", default=None)
    ap.add_argument("--plot", default=None, help="PNG of the tracks")
    ap.add_argument("--plot-errors", default=None, help="PNG of the submarine track's errors")
    a = ap.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    rec, prod, trk, chain = (out / "rec.h5", out / "prod.h5", out / a.tracks_name,
                             out / "chain.toml")
    exe = [sys.executable, "-m", "arrayproc"]
    steps = {}
    if not (a.reuse and rec.exists()):
        steps["simulate"] = _run(exe + ["simulate", a.scenario, "-o", str(rec),
                                        "--no-progress"])
    if not (a.reuse and prod.exists()):
        chain_variant(chain, a.rr_max)
        steps["process"] = _run(exe + ["process", str(rec), "-c", str(chain), "-o", str(prod),
                                       "--no-progress"])
    if not (a.reuse and trk.exists()):
        steps["track"] = _run(exe + ["track", str(prod), "-c", a.tracker, "-o", str(trk)])
    c0 = time.process_time()
    res = evaluate(rec, prod, trk, a.tracker, a.gate, a.cutoff)
    res["evaluate_cpu_s"] = round(time.process_time() - c0, 1)
    res["steps"] = steps
    with open("/proc/loadavg") as fh:
        res["loadavg"] = fh.read().split()[:3]
    p = res.pop("_plot")
    g = read_products(str(trk))["tracks"]
    p["_vel"] = np.stack([np.asarray(g["vx"], float), np.asarray(g["vy"], float)], 1)
    if a.plot:
        plot_tracks(p, a.plot)
    if a.plot_errors and p["principal"] >= 0:
        plot_errors(p, a.plot_errors)
    text = json.dumps(res, indent=1, default=float)
    print(text)
    if a.json:
        Path(a.json).write_text(text + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
