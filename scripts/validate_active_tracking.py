"""Issue 19 on the active scenario: the multi-target tracker (``measurements = "contacts"``)
on the contacts of the active chain, scored against the simulator's /truth.

Runs (each step skipped with ``--reuse`` when its output exists)::

    arrayproc simulate data/scenarios/active_bpsk_long.toml -o OUT/rec.h5
    arrayproc process OUT/rec.h5 -c OUT/chain.toml -o OUT/prod.h5
    arrayproc track OUT/prod.h5 -c data/trackers/active_contacts.toml -o OUT/tracks.h5

``OUT/chain.toml`` is ``data/chains/active.toml`` with the range-rate channels limited to
±``--rr-max`` m/s (the ownship's 3.1 m/s plus the targets') and no range-Doppler maps; the
shipped ±15 m/s bank costs about twice the CPU.

Reported: contacts — the submarine's echo detected per ping (range within 30 m, one of the
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

import h5py
import numpy as np

from arrayproc.evaluate.metrics import over_time, track_scores
from arrayproc.io.products import read_products
from arrayproc.io.text import as_text
from arrayproc.track.manage.tracks import status_names
from arrayproc.track.multi import split_config

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


def _interp(t: np.ndarray, tt: np.ndarray, v: np.ndarray) -> np.ndarray:
    return np.stack([np.interp(t, tt, v[:, i]) for i in range(v.shape[1])], -1)


def _wrap(a: np.ndarray) -> np.ndarray:
    return (a + 180.0) % 360.0 - 180.0


def _mirror(own_xy: np.ndarray, heading_deg: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Mirror image of points p (n, 2) across the array's axis through own_xy (n, 2)."""
    a = np.stack([np.sin(np.radians(heading_deg)), np.cos(np.radians(heading_deg))], -1)
    d = p - own_xy
    return own_xy + 2 * np.sum(d * a, -1, keepdims=True) * a - d


def evaluate(rec: Path, prod: Path, tracks: Path, tracker_cfg: str, gate: float,
             cutoff: float) -> dict:
    """The numbers of the docstring, plus the arrays the figures need (key ``_plot``)."""
    with h5py.File(rec, "r") as f:
        c = float(f.attrs.get("sound_speed", 1500.0))
        ping_t = f["truth/pings/time"][()]
        sub = {k: f[f"truth/sources/submarine/{k}"][()] for k in ("time", "position",
                                                                    "velocity")}
        own = {k: f[f"truth/ownship/{k}"][()] for k in ("time", "position", "velocity",
                                                        "heading")}
        names = [as_text(v) for v in f["truth/scatterers/name"][()]]
        kinds = [as_text(v) for v in f["truth/scatterers/kind"][()]]
        sc_pos = f["truth/scatterers/position0"][()][:, :2]
        echoes = {k: f[f"truth/echoes/{k}"][()] for k in ("ping", "target", "time",
                                                          "range_m", "range_rate_mps")}
    i_sub = names.index("submarine")
    clutter = np.array([k == "clutter" for k in kinds])
    hd_unw = np.unwrap(np.radians(own["heading"]))

    def own_at(t):
        return (_interp(t, own["time"], own["position"]),
                _interp(t, own["time"], own["velocity"]),
                np.degrees(np.interp(t, own["time"], hd_unw)))

    def sub_at(t):
        return _interp(t, sub["time"], sub["position"]), _interp(t, sub["time"],
                                                                 sub["velocity"])

    # ---- contacts against the echoes' truth
    pg = read_products(str(prod))
    cg = next(g for n, g in pg.items() if n != "/" and as_text(g.get("kind")) == "contacts")
    ct = {k: np.asarray(cg[k]) for k in ("ping", "time", "range_m", "bearing_port_deg",
                                         "bearing_stbd_deg", "range_rate_mps", "moving",
                                         "snr_db", "absolute_doppler_mps")}
    n_ping = ping_t.size
    e_pos = np.where(echoes["target"] == i_sub, 0, 1)
    # true bearing of every echo: scatterer at its scattering time from the array at reception
    t_sc = echoes["time"] - echoes["range_m"] / c
    sp = np.where(e_pos[:, None] == 0, sub_at(t_sc)[0], sc_pos[echoes["target"]])
    o_rx = own_at(echoes["time"])[0]
    e_brg = np.degrees(np.arctan2(sp[:, 0] - o_rx[:, 0], sp[:, 1] - o_rx[:, 1]))
    matched_echo = np.full(ct["time"].size, -1)
    loose = np.zeros(ct["time"].size, bool)
    sub_det = np.zeros(n_ping, bool)
    sub_contact_rows = []
    for k in range(n_ping):
        rows = np.flatnonzero(ct["ping"] == k)
        ek = np.flatnonzero(echoes["ping"] == k)
        if rows.size == 0 or ek.size == 0:
            continue
        dr = np.abs(ct["range_m"][rows][:, None] - echoes["range_m"][ek][None])
        db = np.minimum(np.abs(_wrap(ct["bearing_port_deg"][rows][:, None] - e_brg[ek][None])),
                        np.abs(_wrap(ct["bearing_stbd_deg"][rows][:, None] - e_brg[ek][None])))
        tight = (dr < 30.0) & (db < 3.0)
        loose[rows] = ((dr < 60.0) & (db < 5.0)).any(1)
        for a, r in enumerate(rows):
            if tight[a].any():
                matched_echo[r] = ek[np.argmin(np.where(tight[a], dr[a], np.inf))]
        hits = rows[matched_echo[rows] >= 0]
        s_hits = hits[echoes["target"][matched_echo[hits]] == i_sub]
        if s_hits.size:
            sub_det[k] = True
            sub_contact_rows.append(int(s_hits[np.argmax(ct["snr_db"][s_hits])]))
    sr = np.array(sub_contact_rows, np.int64)
    se = matched_echo[sr]
    cl_e = np.flatnonzero(clutter[echoes["target"]])
    cl_hit_rows = np.flatnonzero((matched_echo >= 0)
                                 & clutter[echoes["target"][np.maximum(matched_echo, 0)]])
    cl_echo_detected = np.unique(matched_echo[cl_hit_rows])
    fa = ~loose
    cfg, _tma = split_config(tracker_cfg)
    cc = cfg["contacts"]
    enters = np.ones(ct["time"].size, bool)
    if cc["moving_only"]:
        enters &= ct["moving"].astype(bool)
    if cc["min_snr_db"] > 0:
        enters &= ct["snr_db"] >= cc["min_snr_db"]
    contacts = {
        "entering_tracker": int(enters.sum()),
        "entering_submarine": int(enters[sr].sum()),
        "entering_clutter": int(enters[cl_hit_rows].sum()),
        "entering_false_alarms": int(enters[fa].sum()),
        "n_contacts": int(ct["time"].size), "n_pings": int(n_ping),
        "submarine_detected_pings": int(sub_det.sum()),
        "submarine_range_error_m": _stats(ct["range_m"][sr] - echoes["range_m"][se]),
        "submarine_range_rate_error_mps": _stats(ct["range_rate_mps"][sr]
                                                 - echoes["range_rate_mps"][se]),
        "submarine_snr_db": _stats(ct["snr_db"][sr]),
        "submarine_moving_pings": int(ct["moving"][sr].astype(bool).sum()),
        "clutter_echoes": int(cl_e.size),
        "clutter_echoes_detected": int(cl_echo_detected.size),
        "clutter_contacts": int(cl_hit_rows.size),
        "clutter_contacts_moving": int(ct["moving"][cl_hit_rows].astype(bool).sum()),
        "false_alarms": int(fa.sum()),
        "false_alarms_per_ping": round(float(fa.sum()) / max(1, n_ping), 1),
        "false_alarms_moving": int(ct["moving"][fa].astype(bool).sum()),
        "false_alarm_snr_db": _stats(ct["snr_db"][fa]),
    }

    # ---- tracks
    tg = read_products(str(tracks))["tracks"]
    tid = np.asarray(tg["track_id"], np.int64)
    st = status_names(tg["status"])
    tt = np.asarray(tg["time"], float)
    xy = np.stack([np.asarray(tg["x"], float), np.asarray(tg["y"], float)], 1)
    vxy = np.stack([np.asarray(tg["vx"], float), np.asarray(tg["vy"], float)], 1)
    row = np.asarray(tg["row"], np.int64)
    scan_t = np.unique(tt)
    # scan times are the estimated transmissions: map each to its ping
    ki = np.argmin(np.abs(scan_t[:, None] - ping_t[None]), axis=1)
    scan_err = float(np.abs(scan_t - ping_t[ki]).max()) if scan_t.size else float("nan")
    ping_of = dict(zip(scan_t.tolist(), ki.tolist(), strict=True))
    pk = np.array([ping_of[v] for v in tt], np.int64)
    conf = st == "confirmed"
    s_xy, s_v = sub_at(ping_t)
    truth = s_xy[None]
    ids = np.unique(tid[conf])
    tix = {int(i): pk[conf & (tid == i)] for i in ids}
    tv = {int(i): xy[conf & (tid == i)] for i in ids}
    sc = track_scores(truth, sub_det[None], tix, tv, gate)
    pr = int(sc.principal[0])
    o_xy, o_v, o_hd = own_at(tt)
    s_row_xy, s_row_v = sub_at(tt)
    mirror_sub = _mirror(o_xy, o_hd, s_row_xy)
    sub_track: dict = {"principal": pr, "held": round(float(sc.held[0]), 3),
                       "breaks": int(sc.breaks[0]),
                       "n_detected_pings": int(sc.n_detected[0])}
    if pr >= 0:
        m = conf & (tid == pr)
        lab = sc.labels[pr]
        mm = np.flatnonzero(m)[lab == 0]
        d = xy[mm] - s_row_xy[mm]
        los = s_row_xy[mm] - o_xy[mm]
        u = los / np.linalg.norm(los, axis=1, keepdims=True)
        rr_trk = np.sum(u * (vxy[mm] - o_v[mm]), 1)
        rr_true = np.sum(u * (s_row_v[mm] - o_v[mm]), 1)
        born = tt[tid == pr].min()
        first_conf = tt[m].min()
        sub_track.update({
            "born_ping": int(ping_of[born]), "confirmed_ping": int(ping_of[first_conf]),
            "last_confirmed_ping": int(pk[m].max()),
            "held_pings": int(mm.size),
            "position_error_m": _stats(np.linalg.norm(d, axis=1)),
            "position_error_last_m": round(float(np.linalg.norm(d[-1])), 1),
            "velocity_error_mps": _stats(np.linalg.norm(vxy[mm] - s_row_v[mm], axis=1)),
            "range_rate_error_mps": _stats(rr_trk - rr_true),
            "hits": int(np.sum(row[m] >= 0)), "coasts": int(np.sum(row[m] < 0))})
    # every other confirmed track: what it followed, its confirmed life
    others = []
    cl_xy = sc_pos[clutter]
    for i in ids:
        if int(i) == pr:
            continue
        m = conf & (tid == i)
        p = xy[m]
        d_sub = np.linalg.norm(p - s_row_xy[m], axis=1)
        d_mir = np.linalg.norm(p - mirror_sub[m], axis=1)
        d_cl = np.linalg.norm(p[:, None] - cl_xy[None], axis=-1).min(1)
        cl_mir = _mirror(np.repeat(o_xy[m], len(cl_xy), 0), np.repeat(o_hd[m], len(cl_xy)),
                         np.tile(cl_xy, (m.sum(), 1))).reshape(m.sum(), len(cl_xy), 2)
        d_clm = np.linalg.norm(p[:, None] - cl_mir, axis=-1).min(1)
        frac = {k: float(np.mean(v < gate)) for k, v in
                (("submarine", d_sub), ("submarine_mirror", d_mir), ("clutter", d_cl),
                 ("clutter_mirror", d_clm))}
        best = max(frac, key=frac.get)
        kind = best if frac[best] >= 0.5 else "false_alarms"
        others.append({"track_id": int(i), "class": kind,
                       "confirmed_pings": int(m.sum()),
                       "first_confirmed_ping": int(pk[m].min()),
                       "last_confirmed_ping": int(pk[m].max()),
                       "hits_while_confirmed": int(np.sum(row[m] >= 0)),
                       "hits_total": int(np.sum((tid == i) & (row >= 0))),
                       "snr_db_of_hits": [round(float(ct["snr_db"][r]), 1)
                                          for r in row[(tid == i) & (row >= 0)]]})
    by_class: dict = {}
    for o in others:
        b = by_class.setdefault(o["class"], {"tracks": 0, "max_confirmed_pings": 0,
                                             "longer_than_3_pings": 0})
        b["tracks"] += 1
        b["max_confirmed_pings"] = max(b["max_confirmed_pings"], o["confirmed_pings"])
        b["longer_than_3_pings"] += int(o["confirmed_pings"] > 3)
    est = [xy[conf & (pk == k)] for k in range(n_ping)]
    tp = truth.copy()
    tp[:, ~sub_det] = np.nan
    g = over_time(tp, est, cutoff, 2.0, 2.0)
    n_tent = int(np.unique(tid).size)
    return {
        "contacts": contacts,
        "tracks": {"n_tracks": n_tent, "n_confirmed": int(ids.size),
                   "scan_time_minus_ping_time_max_s": round(scan_err, 3),
                   "submarine": sub_track, "other_confirmed": others,
                   "other_by_class": by_class,
                   "gospa_cutoff_m": cutoff,
                   "gospa_mean_m": round(float(g["gospa"].mean()), 1),
                   "gospa_after_confirmation_mean_m": round(float(
                       g["gospa"][sub_track.get("confirmed_ping", 0):].mean()), 1)},
        "_plot": {"own": own, "sub": sub, "clutter": cl_xy, "ping_t": ping_t,
                  "tid": tid, "conf": conf, "xy": xy, "tt": tt, "row": row,
                  "principal": pr, "others": others, "gospa": g["gospa"],
                  "labels": sc.labels, "sub_at": sub_at, "own_at": own_at},
    }


def _stats(v: np.ndarray) -> dict:
    v = np.asarray(v, float)
    if v.size == 0:
        return {"n": 0}
    return {"n": int(v.size), "mean": round(float(v.mean()), 3),
            "median": round(float(np.median(v)), 3),
            "rms": round(float(np.sqrt(np.mean(v ** 2))), 3),
            "max_abs": round(float(np.abs(v).max()), 3)}


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
