"""The passive target picture end to end: each scenario of
:mod:`arrayproc.evaluate.scenarios.target_picture` run ``simulate → process → track → tma``
with the shipped files only (``chains/towed_passive.toml``, ``trackers/multi_target.toml``,
``tma/tracks.toml``) through the package's command functions, and scored per source against
the recording's ``/truth``:

- **eligible**: the source's strongest tonal stands ≥ :data:`ELIGIBLE_DB` above the TPSW
  background in its beam: per LOFAR snapshot of the scoring window, the TPSW-normalised level
  (the ``lofar`` product) at the beam nearest its true cone angle and the bin nearest the
  tonal's received (Doppler-shifted) frequency, the larger of ±1 bin and ±1 beam around it;
  the median over the window, the largest over its tonals. ``btr_db`` is the same for the
  BTR: the source's beam over the median of all beams (how far its broad band stands out);
- **held**: the share of the last two thirds of the run at which one confirmed track follows
  it (:func:`arrayproc.evaluate.held.held_last_two_thirds`, cone gate :data:`GATE_DEG`); false
  confirmed tracks are those near no source (the tow ship counts as a source: it is one in
  the data, but it is not scored as a contact);
- **TMA**: the preferred solution of its principal track against the true state at the
  solution's ``t0``: the Mahalanobis distance d² of (x, y, vx, vy) against that block of the
  CRLB, given as ``sigma``, the 1-D Gaussian deviation with the same tail probability
  (``P(χ²₄ > d²) = P(|z| > sigma)``, so "within 3σ" is the 99.73 % region of the 4-D bound;
  far in the tail by its asymptote),
  and the range error (% of the true range from the ownship at ``t0``);
- ``line_cone_deg``: the median |cone error| of the line contacts that match one of the
  source's tonals (received frequency within :data:`LINE_MATCH_HZ`).

:func:`run_scenario` runs one scenario, :func:`score_scenario` scores it,
:func:`evaluate` runs several (in parallel), :func:`markdown_table` renders the table.
"""

from __future__ import annotations

import os
import re
import time
import warnings
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import h5py
import numpy as np
from scipy.special import gammaln, ndtri_exp
from scipy.stats import chi2

from arrayproc.evaluate.held import held_last_two_thirds
from arrayproc.evaluate.scenarios.target_picture import SCENARIOS

__all__ = ["ELIGIBLE_DB", "GATE_DEG", "HELD_MIN", "SIGMA_MAX", "RANGE_MAX_PCT", "run_scenario",
           "eligibility", "line_cone_errors", "tma_scores", "score_scenario", "evaluate",
           "markdown_table", "summary"]

#: a source is scored when its strongest tonal stands this far over the TPSW background, dB
ELIGIBLE_DB = 6.0
#: cone-angle gate of a track following a source, deg
GATE_DEG = 5.0
#: acceptance: held share, TMA deviation (1-D equivalent σ), range error (%)
HELD_MIN, SIGMA_MAX, RANGE_MAX_PCT = 0.8, 3.0, 25.0
#: a line contact belongs to a tonal within this of its received frequency, Hz
LINE_MATCH_HZ = 1.0


def _data(name: str) -> str:
    from arrayproc.data import data_path
    return str(data_path(name))


def run_scenario(name: str, out_dir: str, duration: float | None = None,
                 text: str | None = None) -> dict[str, Any]:
    """Run one scenario ``simulate → process → track → tma`` with the shipped files.

    Parameters
    ----------
    name : str
        Scenario name (key of :data:`~arrayproc.evaluate.scenarios.target_picture.SCENARIOS`).
    out_dir : str
        Folder for ``NAME.toml``, ``NAME_rec.h5``, ``NAME_prod.h5``, ``NAME_tracks.h5`` and
        ``NAME_tma.h5`` (existing files are replaced).
    duration : float, optional
        Shortens the scenario (s), as ``simulate --duration``.
    text : str, optional
        Scenario TOML text instead of the named one.

    Returns
    -------
    dict
        ``paths`` (scenario, recording, products, tracks, tma; tma None when no track was
        solved), ``seconds`` per step, ``warnings`` (messages).
    """
    from arrayproc.errors import ArrayprocError
    from arrayproc.evaluate.pipeline import process, simulate, tma, track

    os.makedirs(out_dir, exist_ok=True)
    p = {k: os.path.join(out_dir, f"{name}_{k}.h5") for k in ("rec", "prod", "tracks", "tma")}
    p["scenario"] = os.path.join(out_dir, f"{name}.toml")
    for k in ("rec", "prod", "tracks", "tma"):
        if os.path.exists(p[k]):
            os.remove(p[k])
    with open(p["scenario"], "w") as fh:
        fh.write(text if text is not None else SCENARIOS[name])
    msgs: list[str] = []
    secs: dict[str, float] = {}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        t = time.perf_counter()
        simulate(p["scenario"], p["rec"], duration=duration, warn=msgs.append)
        secs["simulate"] = time.perf_counter() - t
        t = time.perf_counter()
        process(p["rec"], f"{_data('chains')}/towed_passive.toml", p["prod"], warn=msgs.append)
        secs["process"] = time.perf_counter() - t
        t = time.perf_counter()
        track(p["prod"], f"{_data('trackers')}/multi_target.toml", p["tracks"])
        secs["track"] = time.perf_counter() - t
        t = time.perf_counter()
        try:
            tma(p["tracks"], f"{_data('tma')}/tracks.toml", p["tma"])
        except ArrayprocError as e:  # no confirmed track long enough: scored as unsolved
            msgs.append(str(e))
            p["tma"] = None
        secs["tma"] = time.perf_counter() - t
    msgs += [str(w.message) for w in caught]
    return {"paths": p, "seconds": {k: round(v, 1) for k, v in secs.items()}, "warnings": msgs}


def _truth(rec_path: str) -> tuple[dict[str, dict], Any]:
    from arrayproc.io import truth as truth_mod
    from arrayproc.io.recording import Recording
    r = Recording(rec_path, require_geometry=False)
    return truth_mod.sources(r), r


def eligibility(rec_path: str, prod_path: str, t0: float) -> dict[str, dict[str, float]]:
    """Per source (tow ship included) its strongest tonal's TPSW level in its beam and its
    BTR excess, medians over the snapshots at t ≥ ``t0`` (module doc); dB."""
    from arrayproc.io import truth as truth_mod
    with h5py.File(prod_path, "r") as f:
        lt, lc = f["lofar/time"][()], f["lofar/cone_deg"][()]
        lf, lofar = f["lofar/freq"][()], f["lofar/power_db"]
        bt, bc, btr = f["btr/time"][()], f["btr/cone_deg"][()], f["btr/power_db"][()]
        sel = np.flatnonzero(lt >= t0)
        lo = lofar[sel[0]:sel[-1] + 1] if sel.size else np.zeros((0,) + lofar.shape[1:])
    from arrayproc.io.recording import Recording
    out: dict[str, dict[str, float]] = {}
    with Recording(rec_path, require_geometry=False) as r:
        cones = truth_mod.cone_angles(r, lt[sel])
        freqs = truth_mod.tonal_frequencies(r, lt[sel])
        bsel = np.flatnonzero(bt >= t0)
        bcones = truth_mod.cone_angles(r, bt[bsel])
    nb, nf = lc.size, lf.size
    for name, cone in cones.items():
        bi = np.abs(lc[None, :] - cone[:, None]).argmin(axis=1)
        best = -np.inf
        for k in range(freqs[name].shape[1] if name in freqs else 0):
            fi = np.abs(lf[None, :] - freqs[name][:, k][:, None]).argmin(axis=1)
            v = [lo[s, max(b - 1, 0):min(b + 2, nb), max(j - 1, 0):min(j + 2, nf)].max()
                 for s, (b, j) in enumerate(zip(bi, fi, strict=True))]
            if v:
                best = max(best, float(np.median(v)))
        bb = np.abs(bc[None, :] - bcones[name][:, None]).argmin(axis=1)
        rows = btr[bsel]
        ex = [rows[s, max(b - 1, 0):min(b + 2, bc.size)].max() - np.median(rows[s])
              for s, b in enumerate(bb)]
        out[name] = {"tonal_db": round(best, 1) if np.isfinite(best) else None,
                     "btr_db": round(float(np.median(ex)), 1) if ex else None}
    return out


def line_cone_errors(rec_path: str, prod_path: str) -> dict[str, dict[str, float]]:
    """Per source the line contacts matched to its tonals (received frequency within
    :data:`LINE_MATCH_HZ`, the nearest source): their count and median |cone error|, deg."""
    from arrayproc.io import truth as truth_mod
    from arrayproc.io.recording import Recording
    with h5py.File(prod_path, "r") as f:
        t, c, fr = (f[f"lines/{k}"][()] for k in ("time", "cone_deg", "freq_hz"))
    with Recording(rec_path, require_geometry=False) as r:
        cones = truth_mod.cone_angles(r, t)
        freqs = truth_mod.tonal_frequencies(r, t)
    names = sorted(freqs)
    if not names or t.size == 0:
        return {}
    dist = np.stack([np.min(np.abs(freqs[n] - fr[:, None]), axis=1) for n in names])
    j = dist.argmin(axis=0)
    ok = dist.min(axis=0) <= LINE_MATCH_HZ
    out = {}
    for q, n in enumerate(names):
        m = ok & (j == q)
        e = np.abs(c[m] - cones[n][m])
        out[n] = {"lines": int(m.sum()),
                  "median_err_deg": round(float(np.median(e)), 2) if e.size else None}
    return out


def _sigma(d2: float, dim: int) -> float:
    """1-D Gaussian deviation with the tail probability of χ²_dim at d². Far in the tail,
    where ``chi2.logsf`` or ``ndtri_exp`` overflow, their asymptotes: ln P(χ²_k > x) ≈
    −x/2 + (k/2 − 1)·ln(x/2) − ln Γ(k/2), and for ln P(|z| > σ) = y,
    σ² ≈ u − ln u − ln 2π with u = −2y (Mills ratio, first order)."""
    ls = float(chi2.logsf(d2, dim))
    if not np.isfinite(ls):
        ls = -d2 / 2.0 + (dim / 2.0 - 1.0) * np.log(d2 / 2.0) - float(gammaln(dim / 2.0))
    y = ls - np.log(2.0)
    z = float(-ndtri_exp(y))
    if np.isfinite(z):
        return z
    u = -2.0 * y
    return float(np.sqrt(u - np.log(u) - np.log(2.0 * np.pi)))


def tma_scores(rec_path: str, tma_path: str | None, track_ids: dict[str, int]
               ) -> dict[str, dict[str, Any] | None]:
    """Per source the preferred TMA solution of its principal track (``track_ids``: source →
    track id) against the truth at the solution's t0: method, ``d2``, ``sigma``, range and
    its error and CRLB σ (m, %); None when the track has no solution."""
    out: dict[str, dict[str, Any] | None] = {n: None for n in track_ids}
    if tma_path is None:
        return out
    with h5py.File(tma_path, "r") as f:
        g = {k: f[f"tma/{k}"][()] for k in ("track_id", "t0", "x", "y", "vx", "vy", "crlb",
                                            "method", "range_sigma_m")}
        g["preferred"] = f["tma/preferred"][()] if "tma/preferred" in f else \
            np.ones(g["t0"].size, np.int8)
    src, r = _truth(rec_path)
    with r:
        for name, tid in track_ids.items():
            i = np.flatnonzero((g["track_id"] == tid) & (g["preferred"] == 1))
            if tid < 0 or i.size == 0:
                continue
            i = int(i[0])
            t0 = float(g["t0"][i])
            tt, pos = src[name]["time"], src[name]["position"][:, :2]
            xy = np.array([np.interp(t0, tt, pos[:, k]) for k in range(2)])
            v = np.array([(np.interp(t0 + 1, tt, pos[:, k]) - np.interp(t0 - 1, tt, pos[:, k]))
                          / 2.0 for k in range(2)])
            own = r.nav.at(np.array([t0]))[0][0, :2]
            est = np.array([g["x"][i], g["y"][i], g["vx"][i], g["vy"][i]])
            e = est - np.r_[xy, v]
            c = g["crlb"][i][:4, :4]
            d2 = float(e @ np.linalg.solve(c, e))
            rng = float(np.hypot(*(xy - own)))
            rng_est = float(np.hypot(*(est[:2] - own)))
            m = g["method"][i]
            out[name] = {"track_id": int(tid), "method": m.decode() if isinstance(m, bytes)
                         else str(m), "t0": round(t0, 1), "d2": round(d2, 2),
                         "sigma": round(_sigma(d2, 4), 2), "range_m": round(rng, 1),
                         "range_err_pct": round(100 * (rng_est - rng) / rng, 1),
                         "range_sigma_pct": round(100 * float(g["range_sigma_m"][i]) / rng, 1)}
    return out


def score_scenario(name: str, run: dict[str, Any]) -> dict[str, Any]:
    """Score one run of :func:`run_scenario` (module doc): per source (the tow ship apart)
    eligible, held, TMA and the pass of each target; false tracks, the tow ship's tracks."""
    p = run["paths"]
    h = held_last_two_thirds(p["tracks"], GATE_DEG)
    el = eligibility(p["rec"], p["prod"], h["window_s"][0])
    lines = line_cone_errors(p["rec"], p["prod"])
    src, r = _truth(p["rec"])
    r.close()
    kinds = {n: str(s.get("attrs", {}).get("kind", "source")) for n, s in src.items()}
    kinds = {n: k.decode() if isinstance(k, bytes) else k for n, k in kinds.items()}
    principal = dict(zip(h["sources"], h["principal"], strict=True))
    contacts = [n for n in h["sources"] if kinds.get(n) != "towship"]
    tm = tma_scores(p["rec"], p["tma"], {n: principal[n] for n in contacts})
    rows = []
    for n in contacts:
        k = h["sources"].index(n)
        e = el[n]
        eligible = e["tonal_db"] is not None and e["tonal_db"] >= ELIGIBLE_DB
        held = h["held"][k]
        t = tm[n]
        row = {"source": n, "eligible": bool(eligible), **e, "held": held,
               "track": principal[n], "duplicates": h["extra"][k],
               "line_cone_deg": lines.get(n, {}).get("median_err_deg"),
               "lines": lines.get(n, {}).get("lines", 0), "tma": t}
        row["pass"] = {"held": held >= HELD_MIN,
                       "sigma": t is not None and t["sigma"] <= SIGMA_MAX,
                       "range": t is not None and abs(t["range_err_pct"]) <= RANGE_MAX_PCT}
        rows.append(row)
    tow = [principal[n] for n in h["sources"] if kinds.get(n) == "towship"]
    return {"scenario": name, "window_s": h["window_s"], "sources": rows,
            "false_tracks": h["false_tracks"], "n_confirmed": h["n_confirmed"],
            "towship_track": tow[0] if tow else None, "seconds": run["seconds"],
            "n_warnings": len(run["warnings"])}


def reseeded(text: str, offset: int) -> str:
    """Scenario TOML ``text`` with its top-level ``seed`` increased by ``offset`` (another
    draw of every noise and fading process; the geometry and levels unchanged)."""
    if offset == 0:
        return text
    m = re.search(r"(?m)^seed = (\d+)$", text)
    if m is None:
        raise ValueError("the scenario text has no top-level 'seed = N' line")
    return text[:m.start()] + f"seed = {int(m.group(1)) + offset}" + text[m.end():]


def _one(args: tuple[str, str, float | None, int]) -> dict[str, Any]:
    name, out_dir, duration, offset = args
    run = run_scenario(name, out_dir, duration, reseeded(SCENARIOS[name], offset))
    res = score_scenario(name, run)
    res["seed_offset"] = offset
    return res


def evaluate(names: Sequence[str], out_dir: str, jobs: int = 1,
             duration: float | None = None, seeds: int = 1) -> list[dict[str, Any]]:
    """Run and score the named scenarios (``jobs`` processes at once), each on ``seeds``
    noise draws (seed offsets 0, 100, 200, …; the files of offset k > 0 in ``out_dir/sK``);
    one dict each (:func:`score_scenario`, with ``seed_offset``), scenario by scenario."""
    args = [(n, out_dir if k == 0 else os.path.join(out_dir, f"s{100 * k}"), duration,
             100 * k) for n in names for k in range(seeds)]
    if jobs <= 1:
        return [_one(a) for a in args]
    with ProcessPoolExecutor(max_workers=jobs) as ex:
        return list(ex.map(_one, args))


def _fmt(v: Any, spec: str = "") -> str:
    return "–" if v is None else format(v, spec)


def _run_name(res: dict[str, Any]) -> str:
    off = res.get("seed_offset", 0)
    return res["scenario"] + (f" (seed +{off})" if off else "")


def markdown_table(results: Sequence[dict[str, Any]]) -> str:
    """The table per scenario and source (docs/validation/target_picture.md)."""
    head = ("| scenario | source | strongest tonal over TPSW (dB) | BTR excess (dB) | eligible "
            "| held (last ⅔) | line cone error (°, median) | TMA method | TMA σ | range error "
            "| range σ (CRLB) | false tracks |\n" + "|---" * 12 + "|\n")
    lines = []
    for res in results:
        for k, s in enumerate(res["sources"]):
            t = s["tma"] or {}
            ok = s["pass"]
            mark = (lambda b: "" if b else " ✗") if s["eligible"] else (lambda b: "")
            lines.append(
                f"| {_run_name(res) if k == 0 else ''} | {s['source']} | "
                f"{_fmt(s['tonal_db'], '.1f')} | {_fmt(s['btr_db'], '.1f')} | "
                f"{'yes' if s['eligible'] else 'no'} | {100 * s['held']:.0f} %{mark(ok['held'])}"
                f" | {_fmt(s['line_cone_deg'], '.2f')} | {t.get('method', '–')} | "
                f"{_fmt(t.get('sigma'), '.2f')}{mark(ok['sigma'])} | "
                f"{_fmt(t.get('range_err_pct'), '+.1f')} %{mark(ok['range'])} | "
                f"{_fmt(t.get('range_sigma_pct'), '.1f')} % | "
                f"{len(res['false_tracks']) if k == 0 else ''} |")
    return head + "\n".join(lines) + "\n"


def summary(results: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Counts over the runs (scenarios × seeds): sources, eligible ones, and the eligible
    ones that miss each target; the largest number of false tracks in one run."""
    el = [s for r in results for s in r["sources"] if s["eligible"]]
    return {"runs": len(results),
            "sources": sum(len(r["sources"]) for r in results), "eligible": len(el),
            "held_below_80pct": sum(not s["pass"]["held"] for s in el),
            "tma_beyond_3sigma": sum(not s["pass"]["sigma"] for s in el),
            "range_beyond_25pct": sum(not s["pass"]["range"] for s in el),
            "max_false_tracks": max((len(r["false_tracks"]) for r in results), default=0)}
