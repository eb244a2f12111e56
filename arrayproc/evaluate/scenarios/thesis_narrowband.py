"""Thesis section 3.2.1.2 (figs. 3.8-3.9): the narrowband EKF (KAL) against the per-sample CBF
on a simulated 697 Hz tonal.

Hydrophone samples are synthesised here with numpy, not with the scenario simulator: a point
source radiating sin(2π f0 t) (unit amplitude), received at every element with its exact
emission-time delay (so the Doppler of both platforms and the wavefront curvature are in the
samples), plus white Gaussian noise at the stated hydrophone-level SNR (signal power / noise
power over the full 0-fs/2 band). 64 elements spaced 0.36 m, fs 5120 Hz, array on a straight
track. Stationary target: fixed, CPA 5000 m; moving target: reciprocal course at the array's
speed on a parallel track 5000 m off (thesis fig. 3.7). The samples go through the
``dft_filter`` stage (complex baseband, band 677-717 Hz, decimation 64 to 80 Hz), then through
the EKF (dual and single) and the CBF baseline of
:mod:`arrayproc.stages.narrowband.cbf_baseline`.

:func:`run_case` reports the ECDF of the cone error at 0.5° (thesis: −20 dB, stationary, 99 %
KAL vs 80 % CBF), percentiles, errors by cone sector, the largest error within 5 s after each
re-initialisation (single vs dual), and the received-frequency error against the LOFAR bin
width (5120/2048 = 2.5 Hz).
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from arrayproc.chain import Block
from arrayproc.chain.domains import Domain, TimeMeta
from arrayproc.stages.condition.dft_filter import DFTFilter
from arrayproc.stages.narrowband.cbf_baseline import cbf_track
from arrayproc.stages.narrowband.ekf import NarrowbandEKF

__all__ = ["KNOT", "C", "FS", "N_H", "SPACING", "F0", "BAND", "DECIMATE", "LOFAR_BIN_HZ",
           "geometry", "synthesise", "truth", "filtered", "run_ekf", "reinit_times", "ripple",
           "ecdf_at", "stats", "run_case"]

KNOT = 1852.0 / 3600.0
C = 1500.0
FS = 5120.0
N_H = 64
SPACING = 0.36
F0 = 697.0
BAND = (677.0, 717.0)
DECIMATE = 64
LOFAR_BIN_HZ = FS / 2048
SETTLE_S = 10.0  # start-up excluded from the statistics
RIPPLE_S = 5.0
CHUNK_S = 8.0


def geometry(kind: str, speed: float, duration: float, offset: float = 5000.0,
             cone_deg: float | None = None):
    """Array start/velocity and source start/velocity (x east, y north, m and m/s).

    The array runs east along y = 0 and passes abeam of the stationary source at mid-run
    (``stationary``); ``moving``: the source runs west at the same speed on y = offset, CPA at
    mid-run; ``fixed``: a stationary source at ``cone_deg`` from the array's mid-run position.
    """
    va = np.array([speed, 0.0])
    pa = np.array([-0.5 * speed * duration, 0.0])
    if kind == "stationary":
        return pa, va, np.array([0.0, offset]), np.zeros(2)
    if kind == "moving":
        return pa, va, np.array([0.5 * speed * duration, offset]), -va
    th = math.radians(cone_deg)
    return pa, va, np.array([offset * math.cos(th), offset * math.sin(th)]), np.zeros(2)


def _ranges(t: np.ndarray, geo, x: np.ndarray) -> np.ndarray:
    """Emission-time propagation distance r (T, N), m: r = |p_s(t − r/c) − p_n(t)|."""
    pa, va, ps, vs = geo
    u = va / np.linalg.norm(va)
    el = (pa[None, None, :] + t[:, None, None] * va[None, None, :]
          + x[None, :, None] * u[None, None, :])  # (T, N, 2)
    r = np.linalg.norm(ps + t[:, None, None] * vs - el, axis=2)
    if np.any(vs):
        for _ in range(3):  # fixed point of the emission time te = t − r/c
            te = t[:, None] - r / C
            r = np.linalg.norm(ps + te[..., None] * vs - el, axis=2)
    return r


def synthesise(t: np.ndarray, geo, x: np.ndarray, snr_db: float, rng) -> np.ndarray:
    """(T, N) float32 element samples at times t: unit sine from the source with emission-time
    delays, plus noise at hydrophone SNR ``snr_db``.

    The distances are computed exactly every ``SUB`` samples and interpolated linearly in
    between (their curvature over SUB/fs = 3 ms changes them by < 1e-7 m here).
    """
    sub = 16
    tc = t[::sub]
    if tc[-1] != t[-1]:
        tc = np.append(tc, t[-1])
    rc = _ranges(tc, geo, x)
    j = np.minimum(np.searchsorted(tc, t, side="right") - 1, tc.size - 2)
    w = ((t - tc[j]) / (tc[j + 1] - tc[j]))[:, None]
    r = rc[j] * (1 - w) + rc[j + 1] * w
    y = np.sin(2 * np.pi * F0 * (t[:, None] - r / C))
    sigma = math.sqrt(0.5 / 10 ** (snr_db / 10))
    y += sigma * rng.standard_normal(y.shape)
    return y.astype(np.float32)


def truth(t: np.ndarray, geo, x: np.ndarray, speed: float):
    """True cone (deg, from the array centre to the emission position), received frequency at
    the array centre (Hz) and the EKF state frequency f = f_rec / (1 + U cos θ / c)."""
    pa, va, ps, vs = geo
    u = va / np.linalg.norm(va)
    xc = 0.5 * (x.min() + x.max())
    def arr(tt):
        return pa + tt[:, None] * va + xc * u

    r = np.linalg.norm(ps + t[:, None] * vs - arr(t), axis=1)
    for _ in range(3):
        r = np.linalg.norm(ps + (t - r / C)[:, None] * vs - arr(t), axis=1)
    d = ps + (t - r / C)[:, None] * vs - arr(t)
    cone = np.degrees(np.arccos(np.clip(d @ u / np.linalg.norm(d, axis=1), -1, 1)))
    h = 1e-3
    def emit(tt):
        rr = np.linalg.norm(ps + tt[:, None] * vs - arr(tt), axis=1)
        for _ in range(3):
            rr = np.linalg.norm(ps + (tt - rr / C)[:, None] * vs - arr(tt), axis=1)
        return tt - rr / C
    f_rec = F0 * (emit(t + h) - emit(t - h)) / (2 * h)
    f_state = f_rec / (1 + speed * np.cos(np.radians(cone)) / C)
    return cone, f_rec, f_state


def filtered(geo, duration: float, snr_db: float, seed: int):
    """Run the synthesis through the dft_filter stage: complex baseband at FS/DECIMATE."""
    x = -np.arange(N_H) * SPACING  # element 0 forward, body x forward positive
    pos = np.stack([x, np.zeros(N_H), np.zeros(N_H)], axis=1)
    rng = np.random.default_rng(seed)
    stage = DFTFilter(band=list(BAND), taper=0.2, decimate=DECIMATE, complex=True)
    n_chunk = int(CHUNK_S * FS)
    n_tot = int(duration * FS)

    def blocks():
        for i0 in range(0, n_tot, n_chunk):
            i1 = min(n_tot, i0 + n_chunk)
            t = np.arange(i0, i1) / FS
            y = synthesise(t, geo, x, snr_db, rng)
            yield Block(y, Domain.TIME, i0 / FS, (i1 - i0) / FS, FS, pos,
                        meta=TimeMeta(i0, i1 - i0))

    ys, t0 = [], None
    for b in stage.process(blocks()):
        if t0 is None:
            t0 = b.t0
        ys.append(b.data[: b.meta.n_valid])
    y = np.concatenate(ys)
    return x, y, t0, b.fs, b.meta.fc


def run_ekf(y, t0, fs, fc, x, speed, cone0, f0, dual, reinit_s, q, align, block=400,
            spatial_doppler=True):
    ekf = NarrowbandEKF(x, cone0, f0, C, fc=fc, q=q, reinit_s=reinit_s, dual=dual,
                        align_phase=align, spatial_doppler=spatial_doppler)
    outs = [ekf.process(y[i:i + block], t0 + i / fs, fs, speed)
            for i in range(0, y.shape[0], block)]
    return {k: np.concatenate([o[k] for o in outs]) for k in outs[0]}


def reinit_times(t0: float, t1: float, reinit_s: float, dual: bool) -> np.ndarray:
    a = np.arange(t0 + reinit_s, t1, reinit_s)
    if dual:
        a = np.sort(np.concatenate([a, np.arange(t0 + 0.5 * reinit_s, t1, reinit_s)]))
    return a


def ripple(t, err, times):
    """Largest |error| within RIPPLE_S after each re-initialisation time."""
    out = []
    for r in times:
        m = (t >= r) & (t < r + RIPPLE_S)
        if m.any():
            out.append(float(np.max(err[m])))
    return np.array(out)


def ecdf_at(err, v):
    return float(np.mean(err < v))


def stats(err):
    return {"frac_below_0.5deg": ecdf_at(err, 0.5), "frac_below_1deg": ecdf_at(err, 1.0),
            "p50_deg": float(np.percentile(err, 50)), "p90_deg": float(np.percentile(err, 90)),
            "p99_deg": float(np.percentile(err, 99)), "max_deg": float(np.max(err)),
            "rms_deg": float(np.sqrt(np.mean(err ** 2)))}


def run_case(kind: str, snr_db: float, args: Any, seed: int,
             cone_deg: float | None = None) -> tuple[dict, dict]:
    """One scenario at one hydrophone SNR: the EKF variants and the CBF baseline against the
    truth (module docstring).

    Parameters
    ----------
    kind : str
        ``stationary``, ``moving`` or ``fixed`` (a static source at ``cone_deg``).
    snr_db : float
        Hydrophone SNR, dB.
    args
        Settings with attributes ``speed`` (kn), ``duration`` and ``sweep_s`` (s, the latter
        for ``fixed``), ``reinit`` (s), ``sigma_cone`` (deg/√s), ``sigma_freq`` (Hz/√s).
    seed : int
        Seed of the noise.

    Returns
    -------
    (dict, dict)
        The statistics, and the time series the figures need.
    """
    speed = args.speed * KNOT
    geo = geometry(kind, speed, args.duration if cone_deg is None else args.sweep_s,
                   cone_deg=cone_deg)
    dur = args.duration if cone_deg is None else args.sweep_s
    tic = time.perf_counter()
    x, y, t0, fs, fc = filtered(geo, dur, snr_db, seed)
    t_syn = time.perf_counter() - tic
    t = t0 + np.arange(y.shape[0]) / fs
    cone_t, frec_t, fst_t = truth(t, geo, x, speed)
    # start values: 1 deg and 0.2 Hz off the truth, as "the right parameters" at the start
    cone0 = float(cone_t[0] + 1.0)
    f0 = float(fst_t[0] + 0.2)
    q = (args.sigma_cone, args.sigma_freq)
    tic = time.perf_counter()
    kal = run_ekf(y, t0, fs, fc, x, speed, cone0, f0, True, args.reinit, q, True)
    t_kal = time.perf_counter() - tic
    variants = {"kal_dual": kal,
                "kal_single": run_ekf(y, t0, fs, fc, x, speed, cone0, f0, False, args.reinit,
                                      q, True),
                "thesis_dual": run_ekf(y, t0, fs, fc, x, speed, cone0, f0, True, args.reinit,
                                       q, False),
                "thesis_single": run_ekf(y, t0, fs, fc, x, speed, cone0, f0, False,
                                         args.reinit, q, False),
                # the exact moving-array phase (Doppler factor on the time term only)
                "kal_dual_exact_doppler": run_ekf(y, t0, fs, fc, x, speed, cone0, f0, True,
                                                  args.reinit, q, True,
                                                  spatial_doppler=False)}
    cbf = cbf_track(y, fs, x, C, fc=fc, band=BAND, speed=speed)
    ok = t >= t[0] + SETTLE_S
    err = {k: np.abs(v["cone_deg"] - cone_t) for k, v in variants.items()}
    e_k = err["kal_dual"]
    e_c = np.abs(cbf["cone_deg"] - cone_t)
    fd_k = kal["freq_hz"] * (1 + speed * np.cos(np.radians(kal["cone_deg"])) / C)
    ef = np.abs(fd_k - frec_t)
    res = {"scenario": kind, "snr_db": snr_db, "duration_s": dur, "seed": seed,
           "fs_out_hz": fs, "n_samples": int(ok.sum()),
           "cone_range_deg": [float(cone_t.min()), float(cone_t.max())],
           "cbf": stats(e_c[ok]),
           "seconds": {"synthesis_and_dft_filter": t_syn, "ekf_dual": t_kal}}
    for k in variants:
        res[k] = stats(err[k][ok])
    rt_s = reinit_times(t[0], t[-1] - RIPPLE_S, args.reinit, False)
    rt_d = reinit_times(t[0], t[-1] - RIPPLE_S, args.reinit, True)
    res["reinit_ripple"] = {}
    for k in variants:
        r = ripple(t, err[k], rt_s if k.endswith("single") else rt_d)
        res["reinit_ripple"][k + "_max_err_5s_deg"] = {
            "median": float(np.median(r)), "max": float(r.max()), "n": int(r.size)}
    res["frequency"] = {"lofar_bin_hz": LOFAR_BIN_HZ, "max_abs_err_hz": float(ef[ok].max()),
                        "p99_abs_err_hz": float(np.percentile(ef[ok], 99)),
                        "frac_within_bin": ecdf_at(ef[ok], LOFAR_BIN_HZ),
                        "doppler_span_hz": [float(frec_t.min()), float(frec_t.max())]}
    sectors = [(0, 30), (30, 60), (60, 80), (80, 100), (100, 120), (120, 150), (150, 180)]
    sec = {}
    for lo, hi in sectors:
        m = ok & (cone_t >= lo) & (cone_t < hi)
        if m.sum() > 100:
            sec[f"{lo}-{hi}"] = {"n": int(m.sum()),
                                 "kal_frac_below_0.5deg": ecdf_at(e_k[m], 0.5),
                                 "cbf_frac_below_0.5deg": ecdf_at(e_c[m], 0.5),
                                 "kal_p99_deg": float(np.percentile(e_k[m], 99)),
                                 "cbf_p99_deg": float(np.percentile(e_c[m], 99))}
    res["by_cone_sector"] = sec
    series = {"time": t, "truth_cone": cone_t, "truth_freq": frec_t, "kal": kal,
              "single": variants["thesis_single"], "cbf": cbf, "fd_kal": fd_k}
    return res, series
