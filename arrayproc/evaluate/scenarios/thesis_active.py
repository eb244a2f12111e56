"""Thesis chapter 4, the simulated active scenario: contacts against the echo truth.

The scenario (an HFM of the BPSK's band, then the 4 s 2047-bit BPSK 15 s later, every 30 s)
goes through ``active_beams`` -> ``matched_filter`` -> ``cfar`` (full cube) and a second
``matched_filter`` in bracket mode around the previous HFM ping's contacts (thesis 4.2.3).
Scored here, from the products and the recording's ``/truth`` (:func:`score_products`):

- the submarine's echo in each BPSK ping (:func:`submarine_rows`): detected within 30 m and
  10° of the truth, range error in range cells, range-rate error, absolute-Doppler
  classification, and the expected SNR after processing, echo level − noise spectral level
  + 10 log10 T + 10 log10 (elements) − 1.76 dB (Hann shading loss), with blanking
  + 10 log10 of the echo's fraction received after the direct-blast gate
  (:func:`expected_echo_snr_db`);
- clutter (:func:`clutter_figures`): loose gates (30 m, 10°) let false alarms near a clutter
  echo in, so also the contact nearest each clutter echo within two range cells and 3°; near
  range (inside the direct blast) and far;
- the bracket mode (:func:`bracket_figures`): the share of the cells searched and whether it
  finds the same submarine contacts.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from arrayproc.evaluate.association import associate
from arrayproc.io.products import read_products
from arrayproc.io.recording import Recording
from arrayproc.io.truth import echo_truth

__all__ = ["C", "NOISE_DB", "expected_echo_snr_db", "submarine_rows", "submarine_summary",
           "clutter_figures", "bracket_figures", "score_products"]

C = 1500.0
NOISE_DB = 55.0  # noise spectral level of the scenario, dB re 1 µPa²/Hz


def expected_echo_snr_db(level_db: float, noise_db: float, duration_s: float,
                         n_elements: int) -> float:
    """Echo SNR after the matched filter and the beamformer: echo level − noise spectral
    level + 10 log10 T + 10 log10 N − 1.76 dB (the Hann shading loss)."""
    return (level_db - noise_db + 10 * np.log10(duration_s) + 10 * np.log10(n_elements)
            - 1.76)


def _groups(prod: Path) -> tuple[dict, dict | None]:
    g = read_products(prod)
    full = {k: np.asarray(v) for k, v in g["contacts"].items() if k not in ("attrs", "kind",
                                                                            "stage")}
    br = {k: np.asarray(v) for k, v in g["contacts_bracket"].items()
          if k not in ("attrs", "kind", "stage")} if "contacts_bracket" in g else None
    return full, br


def submarine_rows(full: dict, br: dict | None, tr: dict, act, bpsk_pings: list[int],
                   cell: float, n_el: int, rec_end_s: float, gate_end: float,
                   blank: str, noise_db: float = NOISE_DB) -> list[dict]:
    """One row per BPSK ping whose submarine echo lies wholly in the recording: the truth,
    the expected SNR, and the strongest full-cube (and bracket) contact within 30 m and 10°.

    Parameters
    ----------
    full, br : dict
        Contacts of the full cube and of the bracket mode (or None).
    tr : dict
        :func:`arrayproc.io.truth.echo_truth`.
    act
        The recording's active schedule (``time``, ``waveform``, ``waveforms``).
    bpsk_pings : list of int
        Pings of the BPSK.
    cell : float
        Range cell c / 2B, m.
    n_el : int
        Elements.
    rec_end_s : float
        Recording length, s.
    gate_end : float
        End of the direct arrival after the ping, s.
    blank : str
        Blanked waveforms: "" (none), "all" or comma-separated names.
    noise_db : float
        Noise spectral level, dB re 1 µPa²/Hz.

    Returns
    -------
    list of dict
    """
    wv = np.array([x.decode() for x in full["waveform"]])
    T = act.waveforms["bpsk"].duration
    rows = []
    sub = tr["kind"] == "target"
    for p in bpsk_pings:
        k = np.flatnonzero(sub & (tr["ping"] == p))
        if k.size == 0:
            continue
        k = int(k[0])
        if tr["time"][k] + T > rec_end_s:  # echo not wholly in the recording
            continue
        snr_pred = expected_echo_snr_db(tr["level_db"][k], noise_db, T, n_el)
        delay = float(tr["time"][k] - act.time[p])
        if blank in ("all", "bpsk") or "bpsk" in blank.split(","):
            # the part of the echo received after the direct-blast gate
            snr_pred += 10 * np.log10(max(1e-6, min(1.0, (delay - gate_end) / T + 1.0)))
        m = np.flatnonzero((full["ping"] == p) & (wv == "bpsk")
                           & (np.abs(full["range_m"] - tr["range_array_m"][k]) < 30.0)
                           & (np.abs(full["cone_deg"] - tr["cone_deg"][k]) < 10.0))
        row = {"ping": p, "snr_expected_db": float(snr_pred), "delay_s": delay,
               "inside_direct_blast": bool(delay < gate_end),
               "truth_range_m": float(tr["range_array_m"][k]),
               "truth_range_rate": float(tr["range_rate_mps"][k]),
               "truth_cone": float(tr["cone_deg"][k]), "detected": bool(m.size)}
        if m.size:
            j = m[np.argmax(full["snr_db"][m])]
            row.update(range_m=float(full["range_m"][j]),
                       range_err_cells=float((full["range_m"][j] - tr["range_array_m"][k])
                                             / cell),
                       range_rate=float(full["range_rate_mps"][j]),
                       range_rate_err=float(full["range_rate_mps"][j]
                                            - tr["range_rate_mps"][k]),
                       cone=float(full["cone_deg"][j]), snr_db=float(full["snr_db"][j]),
                       abs_doppler=float(full["absolute_doppler_mps"][j]),
                       moving=bool(full["moving"][j]))
        if br is not None:
            mb = np.flatnonzero((br["ping"] == p)
                                & (np.abs(br["range_m"] - tr["range_array_m"][k]) < 30.0)
                                & (np.abs(br["cone_deg"] - tr["cone_deg"][k]) < 10.0))
            row["bracket_detected"] = bool(mb.size)
            if mb.size:
                j = mb[np.argmax(br["snr_db"][mb])]
                row.update(bracket_range_m=float(br["range_m"][j]),
                           bracket_range_rate=float(br["range_rate_mps"][j]),
                           bracket_moving=bool(br["moving"][j]))
            cf = full["cells"][full["ping"] == p]
            cb = br["cells"][br["ping"] == p]
            row["cells_full"] = int(cf[0]) if cf.size else None
            row["cells_bracket"] = int(cb[0]) if cb.size else 0
        rows.append(row)
    return rows


def submarine_summary(rows: list[dict]) -> dict:
    """Detection rate of the echoes expected above 15 dB, the largest range (cells) and
    range-rate errors of those detected, and the share classified moving."""
    res: dict = {}
    strong = [r for r in rows if r["snr_expected_db"] > 15.0]
    det = [r for r in strong if r["detected"]]
    res["detection_rate"] = len(det) / max(1, len(strong))
    res["max_abs_range_err_cells"] = max((abs(r["range_err_cells"]) for r in det), default=None)
    res["max_abs_range_rate_err"] = max((abs(r["range_rate_err"]) for r in det), default=None)
    res["moving_fraction"] = float(np.mean([r["moving"] for r in det])) if det else None
    return res


def clutter_figures(full: dict, tr: dict, act, bpsk_pings: list[int], cell: float,
                    beams: tuple[float, float, int], gate_end: float) -> dict:
    """Clutter echoes detected, their static share and range-rate error under loose and tight
    gates; the echoes inside the direct blast and beyond it (module docstring)."""
    wv = np.array([x.decode() for x in full["waveform"]])
    res: dict = {}
    # clutter: loose gates (30 m, 10 deg) let false alarms near a clutter echo in, so also
    # the contact nearest each clutter echo within two range cells and 3 deg
    sens = wv == "bpsk"
    for name, rg, cg in (("loose_30m_10deg", 30.0, 10.0), ("tight_2cells_3deg", 2 * cell, 3.0)):
        idx = associate(full, tr, range_gate=rg, cone_gate=cg)
        is_cl = (idx >= 0) & (tr["kind"][np.maximum(idx, 0)] == "clutter") & sens
        keep = []
        for e in np.unique(idx[is_cl]):  # one contact per echo: the strongest
            m = np.flatnonzero(is_cl & (idx == e))
            keep.append(m[np.argmax(full["snr_db"][m])])
        keep = np.array(keep, int)
        res[f"clutter_{name}"] = {
            "contacts": int(is_cl.sum()),
            "static_fraction_all": (float(np.mean(~full["moving"][is_cl].astype(bool)))
                                    if is_cl.any() else None),
            "echoes_detected": int(keep.size),
            "static_fraction_per_echo": (float(np.mean(~full["moving"][keep].astype(bool)))
                                         if keep.size else None),
            "range_rate_err_median": (float(np.median(full["range_rate_mps"][keep]
                                                      - tr["range_rate_mps"][idx[keep]]))
                                      if keep.size else None)}
        if name.startswith("loose"):
            res["unassociated_bpsk_contacts"] = int(((idx < 0) & sens).sum())
    res["clutter_echoes_in_bpsk_pings"] = int(np.sum((tr["kind"] == "clutter")
                                                     & np.isin(tr["ping"], bpsk_pings)))
    in_sector = (tr["cone_deg"] >= beams[0]) & (tr["cone_deg"] <= beams[1])
    res["clutter_echoes_in_bpsk_pings_in_sector"] = int(np.sum(
        (tr["kind"] == "clutter") & np.isin(tr["ping"], bpsk_pings) & in_sector))
    # near range: clutter echoes arriving while the direct blast is still received
    idx = associate(full, tr, range_gate=2 * cell, cone_gate=3.0)
    delay_all = tr["time"] - act.time[tr["ping"]]
    for name, lo, hi in (("near_inside_blast", 0.0, gate_end), ("far", gate_end, np.inf)):
        sel = ((tr["kind"] == "clutter") & np.isin(tr["ping"], bpsk_pings)
               & (delay_all >= lo) & (delay_all < hi) & in_sector)
        hit = np.unique(idx[(idx >= 0) & sens])
        det = np.intersect1d(np.flatnonzero(sel), hit)
        near_c = sens & (full["range_m"] < C * gate_end / 2)
        res[f"clutter_{name}"] = {
            "delay_s": [lo, None if not np.isfinite(hi) else hi],
            "echoes": int(sel.sum()), "detected_tight": int(det.size),
            "detected_fraction": float(det.size / max(1, sel.sum()))}
        if name.startswith("near"):
            res[f"clutter_{name}"]["bpsk_contacts_nearer_than_gate"] = int(near_c.sum())
    return res


def bracket_figures(rows: list[dict], act, range_m: float, cone_deg: float,
                    beams: tuple[float, float, int]) -> dict:
    """Cells searched by the bracket mode against the full cube on the pings that follow an
    HFM ping, and whether both find the same submarine contacts."""
    res: dict = {}
    if rows:
        with_prev = [r for r in rows if any(n == "hfm" for n in act.waveform[:r["ping"]])]
        cf = sum(r["cells_full"] or 0 for r in with_prev)
        cb = sum(r["cells_bracket"] for r in with_prev)
        res["bracket"] = {"range_m": range_m, "cone_deg": cone_deg,
                          "pings_with_previous_hfm": [r["ping"] for r in with_prev],
                          "cells_full": cf, "cells_bracket": cb,
                          "cell_fraction": cb / max(cf, 1),
                          # the same against the shipped chain's 181-beam fan (equal cells
                          # per beam; the brackets lie inside the sector)
                          "cell_fraction_of_181_beams": cb / max(cf * 181 / beams[2], 1),
                          "same_submarine_contacts": all(
                              r.get("bracket_detected") == r["detected"]
                              and abs(r.get("bracket_range_m", np.nan)
                                      - r.get("range_m", np.nan)) < 0.5
                              and abs(r.get("bracket_range_rate", np.nan)
                                      - r.get("range_rate", np.nan)) < 0.05
                              for r in with_prev if r["detected"] or r.get("bracket_detected")),
                          "submarine_missed_by_both": [r["ping"] for r in with_prev
                                                       if not r["detected"]
                                                       and not r.get("bracket_detected")]}
    return res.get("bracket", {})


def score_products(rec_path: Path, prod: Path, beams: tuple[float, float, int], blank: str,
                   range_m: float, cone_deg: float) -> dict:
    """All the figures of the module docstring for one products file of the scenario.

    Returns
    -------
    dict
        ``bpsk_pings``, ``hfm_pings``, ``range_cell_m``, ``submarine`` (rows),
        the :func:`submarine_summary`, :func:`clutter_figures` and, with a bracket
        stage, ``bracket``.
    """
    with Recording(rec_path) as rec:
        tr = echo_truth(rec)
        act = rec.active()
        n_el = rec.n_channels
        rec_end_s = rec.n_samples / rec.fs
        pos = rec.positions
    full, br = _groups(prod)
    bpsk_pings = [i for i, n in enumerate(act.waveform) if n == "bpsk"]
    cell = C / (2 * act.waveforms["bpsk"].bandwidth)
    T = act.waveforms["bpsk"].duration
    # end of the direct arrival (s after the ping) at the farthest element, default margin
    gate_end = float(np.max(np.linalg.norm(pos - act.projector, axis=1))) / C + T + 0.02
    res: dict = {"bpsk_pings": len(bpsk_pings), "hfm_pings": len(act.waveform) - len(bpsk_pings),
                 "range_cell_m": cell}
    rows = submarine_rows(full, br, tr, act, bpsk_pings, cell, n_el, rec_end_s, gate_end,
                          blank)
    res["submarine"] = rows
    res.update(submarine_summary(rows))
    res.update(clutter_figures(full, tr, act, bpsk_pings, cell, beams, gate_end))
    if br is not None and rows:
        res["bracket"] = bracket_figures(rows, act, range_m, cone_deg, beams)
    return res
