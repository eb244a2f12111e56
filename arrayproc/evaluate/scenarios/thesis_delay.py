"""Thesis chapter 3 time-delay estimation and compact-array localisation scenarios.

* :func:`delay_mc` — fig. 3.15: Monte Carlo RMS error of the cross-correlation delay (eqs.
  (3.26), (3.27) with FFT interpolation) for white signals of bandwidth W, fs 5120 Hz, T = 1 s,
  against Quazi's bounds (3.28) / (3.29) and the CRLB; the collapse SNR. With ``methods``
  including ``unwrap``, fig. 3.16: the phase-unwrapping LLS estimator (3.30)-(3.36), app. B.
* :func:`phat_echo` — GCC-PHAT (and SCOT, ML) against plain cross-correlation when a copy of
  the source arrives −6 dB, 5 ms late.
* :func:`localisation_mc` — a compact volumetric array localising an impulsive broadband
  source 1-20 m away: position RMSE against the CRLB from the TDOA Fisher information, and
  NEES.

Signals are built in the frequency domain so that every fractional delay is exact
(:func:`band_pair`, :func:`pulse_frames`). Each function draws from one
``numpy.random.default_rng(seed)`` in a fixed order (the numbers of the published tables); the
statistics use :mod:`arrayproc.evaluate.accuracy`.
"""

from __future__ import annotations

import numpy as np

from arrayproc.evaluate.accuracy import crlb_ratio, nees_band, rmse
from arrayproc.geo import tdoa
from arrayproc.stages.delay import bounds
from arrayproc.stages.delay.gcc import GccEstimator
from arrayproc.stages.delay.localise import LocaliseConfig, localise_event
from arrayproc.stages.delay.unwrap import UnwrapEstimator

__all__ = ["FS", "N", "band_pair", "delay_mc", "phat_echo", "compact_array", "pulse_frames",
           "localisation_mc"]

FS = 5120.0
N = 5120  # T = 1 s


# -- signals ---------------------------------------------------------------------------------
def band_pair(rng: np.random.Generator, n_trials: int, n: int, fs: float,
              band: tuple[float, float], taus: np.ndarray, snr: float,
              echo: tuple[float, float] | None = None, colour: float = 0.0,
              circular: bool = False) -> tuple[np.ndarray, tuple[float, float]]:
    """Trials of channels receiving one white band-limited signal at delays ``taus`` (s).

    The signal is built on a 2n-sample (``circular``: n-sample) periodic grid from random
    Fourier coefficients in the band (so any fractional delay is exact); channel c is the
    signal delayed by taus[:, c] (shape (n_trials, n_ch)). Independent white noise of unit
    variance is added; the signal's in-band PSD is ``snr`` times the noise PSD. ``echo`` =
    (gain, delay s) adds to every channel but 0 a copy of its own signal that much later;
    ``colour`` tilts the signal spectrum by f^(−colour) (amplitude), SNR then being the band
    average.

    Returns
    -------
    frames : (n_trials, n, n_ch) float64
    band_used : (f_min, f_max) Hz, the edges of the bins holding the signal.
    """
    ng = n if circular else 2 * n
    f = np.fft.rfftfreq(ng, 1 / fs)
    inb = np.flatnonzero((f >= band[0]) & (f <= band[1]))
    fb = f[inb]
    nb = inb.size
    n_ch = taus.shape[1]
    c = rng.standard_normal((n_trials, nb)) + 1j * rng.standard_normal((n_trials, nb))
    amp = (fb / fb.mean()) ** (-colour) if colour else np.ones(nb)
    amp /= np.sqrt(np.mean(amp**2))
    c *= amp
    # in-band PSD ratio snr with unit noise variance: signal variance snr · 2 W / fs,
    # and var of irfft = 4 nb / ng² per unit coefficient variance (2 per complex value)
    w_eff = nb * fs / ng
    scale = np.sqrt(snr * 2 * w_eff / fs * ng**2 / (4 * nb))
    spec = np.zeros((n_trials, n_ch, f.size), complex)
    for ch in range(n_ch):
        ph = np.exp(-2j * np.pi * fb[None, :] * taus[:, ch, None])
        if echo is not None and ch > 0:
            ph = ph * (1.0 + echo[0] * np.exp(-2j * np.pi * fb * echo[1]))
        spec[:, ch, inb] = c * ph
    x = np.fft.irfft(spec, ng, axis=-1)[:, :, :n] * scale
    x += rng.standard_normal(x.shape)
    return x.transpose(0, 2, 1), (float(fb[0]), float(fb[-1]))


# -- fig. 3.15 / 3.16 ------------------------------------------------------------------------
def delay_mc(runs: int, snrs_db: np.ndarray, width: float, fc: float, seed: int,
             methods: tuple[str, ...] = ("xcorr",), batch: int = 100,
             circular: bool = True) -> dict:
    """RMS delay error per SNR of each method for one bandwidth (true delay 1.3 ms + U(±½
    sample) per trial, search over every lag of the snapshot).

    ``circular``: the snapshot is one period of a periodic signal and the correlation circular
    (the model behind the bounds: both channels hold the same signal samples); otherwise the
    signal runs on and the correlation of the finite windows is linear (zero-padded)."""
    band = (fc - width / 2, fc + width / 2)
    rng = np.random.default_rng(seed)
    est = {"xcorr": GccEstimator(N, FS, 2, 0, band, None, "none", "fft", circular=circular,
                                   candidates=128),
           "unwrap": UnwrapEstimator(N, FS, 0, band)}
    out: dict = {"width_hz": width, "band_hz": list(band), "snr_db": list(map(float, snrs_db)),
                 "circular": circular}
    errs = {m: [] for m in methods}
    sigs = {m: [] for m in methods}
    band_used = band
    for snr_db in snrs_db:
        e = {m: [] for m in methods}
        sig = {m: [] for m in methods}
        left = runs
        while left > 0:
            k = min(batch, left)
            taus = np.zeros((k, 2))
            taus[:, 1] = 1.3e-3 + (rng.random(k) - 0.5) / FS
            x, band_used = band_pair(rng, k, N, FS, band, taus, 10 ** (snr_db / 10),
                                     circular=circular)
            for m in methods:
                d = est[m](x)
                e[m].append(d.tau[:, 1] - taus[:, 1])
                sig[m].append(d.sigma[:, 1])
            left -= k
        for m in methods:
            errs[m].append(np.concatenate(e[m]))
            sigs[m].append(np.concatenate(sig[m]))
    snr = 10 ** (np.asarray(snrs_db) / 10)
    T = N / FS
    out["band_used_hz"] = list(band_used)
    out["crlb_s"] = bounds.crlb(snr, T, *band_used).tolist()
    out["quazi_low_s"] = bounds.quazi_low(snr, T, *band_used).tolist()
    out["quazi_high_s"] = bounds.quazi_high(snr, T, *band_used).tolist()
    for m in methods:
        ee = errs[m]
        out[m] = {"rmse_s": [float(rmse(v)) for v in ee],
                  "std_s": [float(np.std(v)) for v in ee],
                  "median_abs_s": [float(np.median(np.abs(v))) for v in ee],
                  "rms_reported_sigma_s": [float(np.sqrt(np.mean(v**2))) for v in sigs[m]]}
        rm = np.array(out[m]["rmse_s"])
        ratio = crlb_ratio(rm, np.array(out["crlb_s"]))
        out[m]["ratio_to_crlb"] = ratio.tolist()
        # collapse: the lowest SNR from which on every point stays within 2x the bound
        ok = ratio <= 2.0
        i = len(ok)
        while i > 0 and ok[i - 1]:
            i -= 1
        out[m]["collapse_snr_db"] = float(snrs_db[i - 1]) if 0 < i < len(ok) else (
            None if i == len(ok) else float(snrs_db[0]) - 5.0)
        out[m]["first_ok_snr_db"] = float(snrs_db[i]) if i < len(ok) else None
        above = ratio[i + 1:] if i < len(ok) else np.array([])
        out[m]["max_ratio_above_collapse"] = float(above.max()) if above.size else None
        out[m]["min_ratio_above_collapse"] = float(above.min()) if above.size else None
    return out


# -- GCC-PHAT under an echo ------------------------------------------------------------------
def phat_echo(runs: int, seed: int, snr_db: float = 20.0) -> dict:
    """Plain cross-correlation against PHAT (and SCOT, ML) when every non-reference channel
    also receives the source −6 dB, 5 ms later; the source spectrum is red (f^−2 amplitude over
    100-2000 Hz), so the plain correlation's main lobe reaches the echo's."""
    rng = np.random.default_rng(seed)
    band = (100.0, 2000.0)
    taus = np.zeros((runs, 2))
    taus[:, 1] = 2.0e-3 + (rng.random(runs) - 0.5) / FS
    x, _ = band_pair(rng, runs, N, FS, band, taus, 10 ** (snr_db / 10),
                     echo=(10 ** (-6 / 20), 5e-3), colour=2.0)
    out: dict = {"snr_db": snr_db, "echo_gain_db": -6.0, "echo_delay_s": 5e-3,
                 "true_delay_s": 2.0e-3, "runs": runs}
    for w in ("none", "phat", "scot", "ml"):
        d = GccEstimator(N, FS, 2, 0, band, 0.02, w, "fft")(x)
        e = d.tau[:, 1] - taus[:, 1]
        out[w] = {"bias_s": float(np.mean(e)), "rmse_s": float(np.sqrt(np.mean(e**2))),
                  "median_abs_s": float(np.median(np.abs(e))),
                  "frac_within_0p2ms": float(np.mean(np.abs(e) < 2e-4))}
    return out


# -- compact-array localisation --------------------------------------------------------------
def compact_array() -> np.ndarray:
    """A 6-element volumetric array about 1.7 m across (the shape of the real frame in
    ``xav-large-array``), world frame x east, y north, z down, m."""
    return np.array([[-0.86, -0.86, -0.67], [-0.86, -0.86, 0.48], [0.86, -0.86, -0.67],
                     [0.0, 0.0, 0.0], [-0.86, 0.86, -0.67], [0.86, 0.86, 0.67]])


def pulse_frames(rng: np.random.Generator, elements: np.ndarray, src: np.ndarray, c: float,
                 fs: float, n: int, band: tuple[float, float], snr_db: float,
                 t_arrival: float = 0.05) -> np.ndarray:
    """One event: an impulsive broadband source (white in ``band``, Hann-tapered, 20 ms)
    arriving at each element after its travel time (spherical spreading), in unit white noise;
    ``snr_db`` is the in-band PSD ratio during the pulse at 1 m-normalised amplitude of the
    closest element. Delays exact (built in the frequency domain)."""
    ng = 2 * n
    f = np.fft.rfftfreq(ng, 1 / fs)
    inb = (f >= band[0]) & (f <= band[1])
    m = int(0.02 * fs)
    p = np.zeros(ng)
    p[:m] = rng.standard_normal(m) * np.hanning(m)
    P = np.fft.rfft(p)
    P[~inb] = 0
    p = np.fft.irfft(P, ng)
    # scale: in-band PSD during the pulse / noise PSD = snr at the closest element
    var_pulse = np.mean(p[:m] ** 2) / np.mean(np.hanning(m) ** 2) if m else 1.0
    w = band[1] - band[0]
    target = 10 ** (snr_db / 10) * 2 * w / fs
    P = np.fft.rfft(p * np.sqrt(target / var_pulse))
    r = np.linalg.norm(elements - src, axis=1)
    t = t_arrival + (r - r.min()) / c
    gain = r.min() / r
    spec = P[None, :] * gain[:, None] * np.exp(-2j * np.pi * f[None, :] * t[:, None])
    x = np.fft.irfft(spec, ng, axis=-1)[:, :n].T
    return x + rng.standard_normal(x.shape)


def localisation_mc(runs: int, seed: int, snr_db: float = 30.0) -> dict:
    """Position RMSE against the CRLB, and NEES, over ``runs`` events at random positions 1-20 m
    from the compact array; delays by the ``tde`` estimator (plain correlation, FFT
    interpolation), positions by the ``localise`` ML solver; CRLB from the TDOA Fisher
    information with the delay covariance of the bound (common-reference model, see
    :func:`arrayproc.geo.tdoa.reference_covariance`)."""
    rng = np.random.default_rng(seed)
    el = compact_array()
    c, fs, n, band, ref = 1484.0, 32000.0, 4096, (200.0, 4000.0), 3
    maxlag = np.linalg.norm(el - el[ref], axis=1) / c + 2.0 / fs
    est = GccEstimator(n, fs, len(el), ref, band, maxlag, "none", "fft")
    cfg = LocaliseConfig(min_corr=0.0, min_pairs=4, cov_scale="none")
    sq, nees, crlb_tr, n_fail = [], [], [], 0
    for _ in range(runs):
        rr = rng.uniform(1.0, 20.0)
        az = rng.uniform(0, 2 * np.pi)
        el_ang = rng.uniform(-0.3, 0.3)
        src = np.array([rr * np.cos(el_ang) * np.sin(az), rr * np.cos(el_ang) * np.cos(az),
                        rr * np.sin(el_ang)])
        x = pulse_frames(rng, el, src, c, fs, n, band, snr_db)
        d = est(x)
        sol = localise_event(d.tau[0], d.sigma[0], d.corr[0], el, ref, c, cfg)
        if sol is None:
            n_fail += 1
            continue
        # CRLB at the truth with the σ the bound gives for this event's SNRs
        sig = d.sigma[0]
        cov_tau = tdoa.reference_covariance(np.delete(sig, ref))
        F = tdoa.fisher_information(src, el, ref, c, cov_tau)
        C = np.linalg.inv(F)
        e = sol.position - src
        sq.append(e @ e)
        crlb_tr.append(np.trace(C))
        nees.append(float(e @ np.linalg.solve(sol.cov, e)))
    sq, nees, crlb_tr = map(np.asarray, (sq, nees, crlb_tr))
    k = nees.size
    lo, hi = nees_band(3, k)
    return {"runs": runs, "snr_db": snr_db, "localised": int(k), "failed": n_fail,
            "rmse_m": float(np.sqrt(sq.mean())), "crlb_rms_m": float(np.sqrt(crlb_tr.mean())),
            "ratio_rmse_to_crlb": float(np.sqrt(sq.mean() / crlb_tr.mean())),
            "mean_nees": float(nees.mean()), "nees_band_95": [float(lo), float(hi)],
            "median_nees": float(np.median(nees))}
