"""Several sources at once on a compact array: two simultaneous transients, each localised from
the K-peak delays and their closure association, against the Cramér-Rao bound.

Each run builds one snapshot in which two broadband bursts (white in the band, Tukey-tapered,
exact fractional delays from the frequency domain, spherical spreading) arrive at the array
together, in unit white noise; :class:`~arrayproc.stages.delay.peaks.PairPeakEstimator` keeps
the K strongest peaks of every pair, :func:`~arrayproc.stages.delay.closure.closure_hypotheses`
forms the sources, each hypothesis is matched to a true source (least squares on the delays,
``scipy.optimize.linear_sum_assignment``) and localised by
:func:`~arrayproc.stages.delay.localise.localise_event`. The bound of each source is the
inverse TDOA Fisher information at its true position
(:func:`arrayproc.geo.tdoa.crlb`) with the delay covariance of its per-channel SNRs
(:func:`arrayproc.stages.delay.bounds.arrival_variance`,
:func:`arrayproc.geo.tdoa.arrival_covariance`) with the other source counted as absent (so the
ratio also measures what the interference costs); the same bound with the other source
counted as white noise (SNR_s/(1 + SNR_other)) is given beside it. A control run of each
source alone, through the one-peak estimator, gives the same ratio without interference.
Every draw comes from one ``numpy.random.default_rng(seed)`` per run (seeds ``seed``,
``seed + 1``, …).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import linear_sum_assignment

from arrayproc.evaluate.accuracy import nees_band
from arrayproc.geo import tdoa
from arrayproc.sim.scenario import tetrahedron
from arrayproc.stages.delay import bounds
from arrayproc.stages.delay.closure import closure_hypotheses
from arrayproc.stages.delay.gcc import GccEstimator
from arrayproc.stages.delay.localise import LocaliseConfig, localise_event
from arrayproc.stages.delay.peaks import PairPeakEstimator, all_pairs

__all__ = ["TwoSourceCase", "burst_frames", "two_source_mc", "CASES"]


@dataclass(frozen=True)
class TwoSourceCase:
    """One geometry and signal set of :func:`two_source_mc`.

    Attributes
    ----------
    name : str
    elements : (n, 3) ndarray
        Element positions, m (x east, y north, z down).
    reference : int
    sources : (2, 3) ndarray
        True source positions, m.
    snr_db : (2,) tuple
        In-band SNR during each burst at the element closest to it, dB.
    onsets : (2,) tuple
        Arrival of each burst at its closest element, s after the snapshot start.
    fs, n, band, duration, c
        Sample rate (Hz), snapshot samples, band (Hz), burst length (s), sound speed (m/s).
    weighting : str
        GCC weighting of the pair search.
    """

    name: str
    elements: np.ndarray
    reference: int
    sources: np.ndarray
    snr_db: tuple[float, float] = (20.0, 17.0)
    onsets: tuple[float, float] = (0.01, 0.02)
    fs: float = 8000.0
    n: int = 1024
    band: tuple[float, float] = (200.0, 3000.0)
    duration: float = 0.1
    c: float = 1480.0
    weighting: str = "none"
    peaks: int = 3
    extra: dict = field(default_factory=dict)


def _tetra_case() -> TwoSourceCase:
    # the compact-array paper's 1.84 m tetrahedron; two sources 3 and 3.5 m off, 160° apart
    az = np.radians([40.0, 200.0])
    return TwoSourceCase("tetrahedron 1.84 m", tetrahedron(1.84), 3,
                         np.array([[3.0 * np.sin(az[0]), 3.0 * np.cos(az[0]), 0.8],
                                   [3.5 * np.sin(az[1]), 3.5 * np.cos(az[1]), -0.5]]))


def _frame_case() -> TwoSourceCase:
    from arrayproc.evaluate.scenarios.thesis_delay import compact_array

    # the six-hydrophone frame's shape (xav-large-array), fish-like band at 32 kHz
    return TwoSourceCase("six-hydrophone frame 1.7 m", compact_array(), 3,
                         np.array([[1.5, -2.0, 0.5], [-2.5, 1.0, 1.2]]), (20.0, 17.0),
                         (0.005, 0.012), 32000.0, 4096, (200.0, 4000.0), 0.08, 1484.0)


#: the cases of ``scripts/validate_multi_source.py``
CASES = {"tetrahedron": _tetra_case, "frame": _frame_case}


def burst_frames(rng: np.random.Generator, case: TwoSourceCase, which: tuple[int, ...] = (0, 1)
                 ) -> tuple[np.ndarray, np.ndarray]:
    """One snapshot (n, n_ch) with the bursts of the sources ``which`` in unit white noise, and
    the in-band SNR of each source at each channel averaged over the snapshot (2, n_ch)."""
    el, n, fs = case.elements, case.n, case.fs
    ng = 2 * n
    f = np.fft.rfftfreq(ng, 1 / fs)
    inb = (f >= case.band[0]) & (f <= case.band[1])
    m = int(round(case.duration * fs))
    w = np.ones(m)
    e = max(1, int(0.05 * m))  # Tukey taper of 10 %: 5 % each side
    w[:e] = 0.5 - 0.5 * np.cos(np.pi * np.arange(e) / e)
    w[-e:] = w[:e][::-1]
    x = np.zeros((n, el.shape[0]))
    snr = np.zeros((len(case.sources), el.shape[0]))
    noise_band = 2 * (case.band[1] - case.band[0]) / fs  # in-band share of unit white noise
    for s in which:
        p = np.zeros(ng)
        p[:m] = rng.standard_normal(m) * w
        P = np.fft.rfft(p)
        P[~inb] = 0
        q = np.fft.irfft(P, ng)[:m]
        var = np.mean(q**2) / np.mean(w**2)
        s_lin = 10 ** (case.snr_db[s] / 10)
        P *= np.sqrt(s_lin * noise_band / var)
        r = np.linalg.norm(el - case.sources[s], axis=1)
        t = case.onsets[s] + (r - r.min()) / case.c
        gain = r.min() / r
        spec = P[None, :] * gain[:, None] * np.exp(-2j * np.pi * f[None, :] * t[:, None])
        x += np.fft.irfft(spec, ng, axis=-1)[:, :n].T
        snr[s] = s_lin * gain**2 * m * np.mean(w**2) / n
    return x + rng.standard_normal(x.shape), snr


def _bound(case: TwoSourceCase, s: int, snr: np.ndarray, other: np.ndarray | None = None
           ) -> np.ndarray:
    """CRLB of source s's position: its per-channel SNRs, the other source absent, or (with
    ``other``, the other's SNRs) counted as white noise, SNR_s/(1 + SNR_other)."""
    if other is not None:
        snr = snr / (1.0 + other)
    v = bounds.arrival_variance(snr, case.n / case.fs, *case.band)
    C = tdoa.arrival_covariance(v, case.reference)
    return tdoa.crlb(case.sources[s], case.elements, case.reference, case.c, C)


def _positive(C: np.ndarray) -> bool:
    """A usable covariance: finite and positive definite (a source whose delays no position
    fits lands where the Fisher information is singular)."""
    if not np.all(np.isfinite(C)):
        return False
    lam = np.linalg.eigvalsh(0.5 * (C + C.T))
    return bool(lam[0] > 1e-9 * lam[-1])


def _delay_summary(d: list, case: TwoSourceCase, snr: np.ndarray, other: np.ndarray) -> dict:
    """RMS and median absolute error of the matched delays (all runs, every channel but the
    reference; left-out delays counted apart, gross errors beyond 10 σ of the bound with the
    other source as noise counted) against the bound's RMS σ, the other source absent and as
    noise."""
    if not d:
        return {"delay_rows": 0}
    e = np.asarray(d)
    T, ref = case.n / case.fs, case.reference

    def rms_bound(s_lin: np.ndarray) -> float:
        v = bounds.arrival_variance(s_lin, T, *case.band)
        return float(np.sqrt(np.mean(np.delete(v, ref) + v[ref])))

    ok = np.isfinite(e)
    rm = float(np.sqrt(np.mean(e[ok] ** 2)))
    a = np.abs(e[ok])
    b0, b1 = rms_bound(snr), rms_bound(snr / (1.0 + other))
    return {"delay_rows": int(e.shape[0]), "delays_left_out": int((~ok).sum()),
            "delay_rmse_s": rm, "delay_median_abs_s": float(np.median(a)),
            "delay_gross_errors": int(np.sum(a > 10 * b1)), "delay_crlb_rms_s": b0,
            "delay_ratio": rm / b0, "delay_crlb_interference_rms_s": b1}


def _summary(err: list, cov: list, crlb_tr: float, runs: int) -> dict:
    e = np.asarray(err).reshape(-1, 3)
    k = e.shape[0]
    if k == 0:
        return {"localised": 0, "runs": runs}
    sq = np.sum(e**2, axis=1)
    nees = np.array([ei @ np.linalg.solve(ci, ei) for ei, ci in zip(e, cov, strict=True)])
    lo, hi = nees_band(3, k)
    rm = float(np.sqrt(sq.mean()))
    return {"runs": runs, "localised": int(k), "rmse_m": rm, "crlb_rms_m": float(np.sqrt(crlb_tr)),
            "ratio_rmse_to_crlb": rm / float(np.sqrt(crlb_tr)), "mean_nees": float(nees.mean()),
            "median_nees": float(np.median(nees)), "nees_band_95": [float(lo), float(hi)]}


def two_source_mc(case: TwoSourceCase, runs: int, seed: int, gate_sigmas: float = 10.0) -> dict:
    """Both sources of ``case`` over ``runs`` seeds: found, localised, RMSE against the CRLB.

    A source is *found* in a run when a hypothesis is matched to it and localised within
    ``gate_sigmas`` times the RMS of its bound with the other source as noise (larger errors
    are counted as outliers, not in the RMSE).

    Returns
    -------
    dict
        Per source (``source0``, ``source1``): ``found``, ``outliers``, the statistics of the
        two-source run (``rmse_m``, ``crlb_rms_m``, ``ratio_rmse_to_crlb``, ``mean_nees``,
        ``nees_band_95``) and ``alone`` (the same for the source alone, one-peak estimator);
        ``both_found`` (runs with both found) and ``hypotheses`` (histogram of the number of
        sources per run).
    """
    el, ref, c = case.elements, case.reference, case.c
    pairs = all_pairs(el.shape[0])
    lag = np.linalg.norm(el[pairs[:, 0]] - el[pairs[:, 1]], axis=1) / c + 1e-4
    est = PairPeakEstimator(case.n, case.fs, lag, pairs, el.shape[0], case.band, case.peaks,
                            case.weighting)
    one = GccEstimator(case.n, case.fs, el.shape[0], ref, case.band,
                       np.linalg.norm(el - el[ref], axis=1) / c + 1e-4, case.weighting, "fft")
    cfg = LocaliseConfig(min_corr=0.0, min_pairs=3, cov_scale="none", max_range=100.0)
    floor = 0.2 / est.gcc.band_width
    truth = tdoa.predicted_delays(case.sources, el, ref, c)
    out: dict = {"case": case.name, "runs": runs, "seed": seed, "peaks": case.peaks,
                 "weighting": case.weighting}
    err = [[], []]
    cov = [[], []]
    err1 = [[], []]
    cov1 = [[], []]
    found = np.zeros((runs, 2), bool)
    outl = [0, 0]
    n_hyp = []
    crlb_tr = [0.0, 0.0]
    crlb_int = [0.0, 0.0]
    dly = [[], []]
    for r in range(runs):
        rng = np.random.default_rng(seed + r)
        x, snr = burst_frames(rng, case)
        pk = est(x)
        h = closure_hypotheses(pk.tau[0], pk.sigma[0], pk.corr[0], pairs, el.shape[0], ref, 2,
                               4.0, floor, 0.7)
        n_hyp.append(h.tau.shape[0])
        for s in range(2):
            crlb_tr[s] = float(np.trace(_bound(case, s, snr[s])))
            crlb_int[s] = float(np.trace(_bound(case, s, snr[s], snr[1 - s])))
        if h.tau.shape[0]:
            cost = np.sum((h.tau[:, None, :] - truth[None]) ** 2, axis=-1)
            hi_, si_ = linear_sum_assignment(cost)
            for hh, s in zip(hi_, si_, strict=True):
                dly[s].append(np.delete(h.tau[hh] - truth[s], ref))
                sol = localise_event(h.tau[hh], h.sigma[hh], h.corr[hh], el, ref, c, cfg)
                if sol is None or not _positive(sol.cov):
                    continue
                e = sol.position - case.sources[s]
                if np.sqrt(e @ e) > gate_sigmas * np.sqrt(crlb_int[s]):
                    outl[s] += 1
                    continue
                found[r, s] = True
                err[s].append(e)
                cov[s].append(sol.cov)
        for s in range(2):  # the control: this source alone, one peak
            xa, _ = burst_frames(np.random.default_rng(seed + r), case, (s,))
            d = one(xa)
            sol = localise_event(d.tau[0], d.sigma[0], d.corr[0], el, ref, c, cfg)
            if sol is not None and _positive(sol.cov):
                err1[s].append(sol.position - case.sources[s])
                cov1[s].append(sol.cov)
    for s in range(2):
        out[f"source{s}"] = {"position_m": case.sources[s].tolist(),
                             "snr_db": case.snr_db[s], "found": int(found[:, s].sum()),
                             "outliers": outl[s], **_summary(err[s], cov[s], crlb_tr[s], runs),
                             "crlb_interference_rms_m": float(np.sqrt(crlb_int[s])),
                             "ratio_rmse_to_crlb_interference": (
                                 float(np.sqrt(np.mean(np.sum(np.asarray(err[s]) ** 2, axis=1))
                                               / crlb_int[s])) if err[s] else None),
                             **_delay_summary(dly[s], case, snr[s], snr[1 - s]),
                             "alone": _summary(err1[s], cov1[s], crlb_tr[s], runs)}
    out["both_found"] = int(found.all(axis=1).sum())
    out["hypotheses"] = {str(k): int(v) for k, v in zip(*np.unique(n_hyp, return_counts=True),
                                                          strict=True)}
    return out
