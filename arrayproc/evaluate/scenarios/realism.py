"""Realistic-ocean set-ups: image-source multipath, reverberation, and the water-pulled
array in a turn (docs/validation/realism.md), with their closed forms.

- :func:`ranged_scenario`, :func:`tonal_phasor` and :func:`two_path` — Lloyd's mirror: one
  static hydrophone per range, the tonal's complex amplitude per channel, and the two-path
  closed form.
- :func:`active_scenario` and :func:`sonar_equation_intensity` — one CW ping and the
  monostatic bottom reverberation level of the sonar equation.
- :func:`turn_scenario`, :func:`turn_chain_text` and :func:`turn_bearing_errors` — bearings
  through a turn with the rigid and the threaded array geometry.
- :func:`clutter_doppler` — the absolute Doppler of drifting clutter's contacts against its
  closed form.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from arrayproc.chain import build_chain, run_chain
from arrayproc.io.products import ProductsWriter, read_products
from arrayproc.io.recording import Recording
from arrayproc.io.truth import cone_angles
from arrayproc.sim.scenario import parse_scenario

__all__ = ["C", "FS", "T_TURN", "TURN_NL", "TURN_RATE", "TURN_V", "active_scenario",
           "clutter_doppler",
           "ranged_scenario", "sonar_equation_intensity", "tonal_phasor", "turn_bearing_errors",
           "turn_chain_text", "turn_scenario", "two_path"]

C = 1500.0  # sound speed, m/s
FS = 4096.0  # sample rate of the active set-up, Hz


def ranged_scenario(ranges, zs, zr, multipath, fs=4096.0, duration=0.5, source=None):
    """A static source at the origin and one static hydrophone per range (north of it)."""
    pos = [[float(r), 0.0, 0.0] for r in ranges]
    src = source or {"tonals": [{"freq": 1000.0, "level_db": 120.0, "phase_deg": 0.0}]}
    return parse_scenario({
        "recording": {"fs": fs, "duration": duration, "sound_speed": C, "seed": 3},
        "array": {"type": "positions", "positions": pos, "depth": zr},
        "source": [{"name": "s", "start": [0.0, 0.0], "depth": zs, "heading": 0.0, **src}],
        "propagation": {"multipath": multipath},
    })


def tonal_phasor(x: np.ndarray, f: float, fs: float) -> np.ndarray:
    """Complex amplitude of a tonal in each column (integer number of cycles)."""
    t = np.arange(x.shape[0]) / fs
    return 2 * np.mean(x * np.exp(-2j * np.pi * f * t)[:, None], axis=0)


def two_path(r, zs, zr, f, refl):
    """Lloyd's mirror: A·|e^{-ikR1}/R1 + R·e^{-ikR2}/R2| (complex, exp(+iωt) convention)."""
    k = 2 * np.pi * f / C
    r1 = np.hypot(r, zs - zr)
    r2 = np.hypot(r, zs + zr)
    return np.exp(-1j * k * r1) / r1 + refl * np.exp(-1j * k * r2) / r2


def active_scenario(extra: dict, duration: float, seed: int = 1, pulse: float = 0.01,
                    zr: float = 20.0) -> dict:
    """One hydrophone and one CW ping (1 kHz, 200 dB, ``pulse`` s at 0.1 s) with the
    ``[active]`` keys ``extra`` (reverberation, targets, features), as a scenario mapping."""
    return {
        "recording": {"fs": FS, "duration": duration, "sound_speed": C, "seed": seed},
        "array": {"type": "line", "n": 1, "spacing": 1.0, "depth": zr},
        "ownship": {"start": [0.0, 0.0], "heading": 0.0},
        "active": {"waveform": "cw", "fc": 1000.0, "duration": pulse, "taper": 0.0,
                   "level_db": 200.0, "interval": 100.0, "first": 0.1, "count": 1,
                   "offset": [0.0, 0.0, 0.0], "direct": False, **extra},
    }


def sonar_equation_intensity(t: np.ndarray, sl: float, mu_db: float, depth: float, zr: float,
                             pulse: float) -> np.ndarray:
    """Mean-square pressure (Pa²) of monostatic bottom reverberation at time t after the
    ping's start: 10^{RL/10}·1e-12 with RL = SL − 40 log10 R + 10 log10(μ sin²θ) +
    10 log10(A), A = 2πr·(cT/2)·(R/r) the ensonified ring (R slant range of the ring's
    centre, r its horizontal range, sin θ = (D − z)/R)."""
    big_r = C * (t - 0.5 * pulse) / 2
    h = depth - zr
    ok = big_r > h
    big_r = np.where(ok, big_r, np.nan)
    r = np.sqrt(big_r**2 - h**2)
    sin_t = h / big_r
    area = 2 * np.pi * r * (C * pulse / 2) * (big_r / r)
    rl = sl - 40 * np.log10(big_r) + mu_db + 20 * np.log10(sin_t) + 10 * np.log10(area)
    return 1e-12 * 10 ** (rl / 10)


TURN_V = 2.5  # m/s
TURN_RATE = 1.5  # deg/s
T_TURN = 20.0  # s on the first leg
TURN_NL = 60.0


def turn_scenario(duration: float = 100.0) -> str:
    """A 32-element water-pulled array through a 1.5 deg/s starboard turn after ``T_TURN`` s
    on the first leg, one broadband source (150-480 Hz), as scenario text."""
    # source at ~1.2 km, 60 deg to starboard of the first course at the start
    r, brg = 1200.0, math.radians(90.0 + 60.0)
    x, y = r * math.sin(brg), r * math.cos(brg)
    return f"""
[recording]
fs = 2048.0
duration = {duration}
seed = 5
nav_interval = 1.0

[array]
type = "line"
n = 32
spacing = 1.5
depth = 60.0
shape = "water_pulled"

[ownship]
start = [0.0, 0.0]
[[ownship.leg]]
course = 90.0
speed = {TURN_V}
duration = {T_TURN}
[[ownship.leg]]
course = 200.0
speed = {TURN_V}
turn_rate = {TURN_RATE}
turn = "starboard"
duration = {duration + 10.0}

[[source]]
name = "s"
start = [{x:.1f}, {y:.1f}]
depth = 50.0
heading = 0.0
[source.broadband]
band = [150.0, 480.0]
level_db = {TURN_NL + 20 * math.log10(r) - 5.0:.2f}

[noise]
level_db = {TURN_NL}
"""


def turn_chain_text(shape: str) -> str:
    """The turn's chain (CBF over 360 bearings, sliding integration, BTR) with
    ``array_shape = shape``."""
    bearings = ", ".join(f"{b:.1f}" for b in np.arange(0.0, 360.0, 1.0))
    return f"""
[input]
block = 8192
array_shape = "{shape}"

[[stage]]
type = "cbf"
nfft = 4096
hop = 4096
window = "hann"
band = [150.0, 480.0]
beams = {{ bearings = [{bearings}] }}
batch = 4

[[stage]]
type = "integrate"
snapshots = 2
mode = "sliding"

[[stage]]
type = "btr"
band = [150.0, 480.0]
"""


def turn_bearing_errors(rec_path: Path, shape: str, tmp: Path) -> tuple[np.ndarray, np.ndarray]:
    """(time, cone-angle error deg) of the BTR's peak beam against the truth."""
    spec = build_chain(turn_chain_text(shape))
    prod = tmp / f"p_{shape}.h5"
    with Recording(rec_path) as rec, ProductsWriter(prod, source=str(rec_path),
                                                    chain=spec.text) as w:
        run_chain(rec, spec, w)
    g = read_products(prod)["btr"]
    with Recording(rec_path) as rec:
        cone_true = cone_angles(rec, g["time"])["s"]
    brg = g["cone_deg"][np.argmax(g["power_db"], axis=1)]
    cone_est = np.rad2deg(np.arccos(np.cos(np.deg2rad(brg))))  # relative bearing → cone
    return g["time"], cone_est - cone_true


KNOT = 1852.0 / 3600.0  # m/s


def clutter_doppler(products: str | Path, recording: str | Path, sigma: float,
                    range_gate: float, cone_gate: float = 3.0, static_kn: float = 2.0) -> dict:
    """The absolute Doppler of drifting clutter's contacts against its closed form.

    Clutter drifting at a horizontal velocity N(0, σ²) per axis (``[active.clutter]
    drift_speed_std``) has a radial speed N(0, σ²) along any line of sight, so the share of
    clutter contacts classified static is P(|v| < u) = erf(u / (σ √2)) with u = ``static_kn``
    knots (thesis 4.2.5 classifies |absolute Doppler| < 2 kn as static).

    Parameters
    ----------
    products, recording : path
        An active products file (``contacts``) and its simulated recording (echo truth).
    sigma : float
        The clutter's drift speed σ, m/s.
    range_gate, cone_gate : float
        Association gates, m and deg (one contact per clutter echo: the strongest BPSK
        contact within them).
    static_kn : float
        The static threshold, kn.

    Returns
    -------
    dict
        ``contacts``; ``static_fraction`` of the contacts and its closed form
        (``closed_form_static_fraction``); ``ks_distance``, the largest gap between the
        contacts' ECDF of |v| and the closed form's; ``abs_doppler_kn``, the sorted |v| (kn).
        (The truth's echo range rates are relative to the moving ownship, so they are not
        the absolute Doppler this compares.)
    """
    from math import erf, sqrt

    from arrayproc.evaluate.association import associate
    from arrayproc.io.truth import echo_truth

    full = read_products(products)["contacts"]
    with Recording(recording) as rec:
        tr = echo_truth(rec)
    wv = np.array([x.decode() for x in full["waveform"]])
    idx = associate(full, tr, range_gate=range_gate, cone_gate=cone_gate)
    is_cl = (idx >= 0) & (tr["kind"][np.maximum(idx, 0)] == "clutter") & (wv == "bpsk")
    keep = np.array([m[np.argmax(full["snr_db"][m])] for e in np.unique(idx[is_cl])
                     for m in [np.flatnonzero(is_cl & (idx == e))]], int)
    v = np.sort(np.abs(full["absolute_doppler_mps"][keep]) / KNOT)

    def cdf(u_kn: np.ndarray) -> np.ndarray:
        return np.array([erf(u * KNOT / (sigma * sqrt(2.0))) for u in np.atleast_1d(u_kn)])

    ks = (float(max(np.max(np.arange(1, v.size + 1) / v.size - cdf(v)),
                    np.max(cdf(v) - np.arange(v.size) / v.size))) if v.size else None)
    return {"contacts": int(v.size),
            "static_fraction": float(np.mean(v < static_kn)) if v.size else None,
            "closed_form_static_fraction": float(cdf(static_kn)[0]),
            "ks_distance": ks, "abs_doppler_kn": v.tolist()}
